#include "bench/transmission/draco_codec.h"

#include <draco/compression/decode.h>
#include <draco/compression/encode.h>
#include <draco/point_cloud/point_cloud_builder.h>

#define RGBDCAST_DRACO_EXPORT __attribute__((visibility("default")))

namespace rgbdcast::bench {

RGBDCAST_DRACO_EXPORT std::vector<std::uint8_t> draco_encode_points(const std::vector<float>& positions,
                                                                    const std::vector<std::uint8_t>& colors,
                                                                    int position_bits, std::string* error) {
  const size_t n = positions.size() / 3;
  if (colors.size() != 3 * n || n == 0) {
    *error = "draco: positions and colours disagree or are empty";
    return {};
  }
  draco::PointCloudBuilder builder;
  builder.Start(static_cast<draco::PointIndex::ValueType>(n));
  const int pos = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
  const int col = builder.AddAttribute(draco::GeometryAttribute::COLOR, 3, draco::DT_UINT8);
  builder.SetAttributeValuesForAllPoints(pos, positions.data(), 3 * sizeof(float));
  builder.SetAttributeValuesForAllPoints(col, colors.data(), 3);
  std::unique_ptr<draco::PointCloud> pc = builder.Finalize(false);
  draco::Encoder encoder;  // default speed
  encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, position_bits);
  draco::EncoderBuffer buffer;
  const draco::Status st = encoder.EncodePointCloudToBuffer(*pc, &buffer);
  if (!st.ok()) {
    *error = std::string("draco: ") + st.error_msg();
    return {};
  }
  return std::vector<std::uint8_t>(buffer.data(), buffer.data() + buffer.size());
}

RGBDCAST_DRACO_EXPORT bool draco_decode_points(const std::uint8_t* data, size_t size, std::vector<float>* positions,
                                               std::vector<std::uint8_t>* colors, std::string* error) {
  draco::DecoderBuffer buffer;
  buffer.Init(reinterpret_cast<const char*>(data), size);
  draco::Decoder decoder;
  auto decoded = decoder.DecodePointCloudFromBuffer(&buffer);
  if (!decoded.ok()) {
    *error = std::string("draco: ") + decoded.status().error_msg();
    return false;
  }
  const std::unique_ptr<draco::PointCloud> pc = std::move(decoded).value();
  const draco::PointAttribute* pos = pc->GetNamedAttribute(draco::GeometryAttribute::POSITION);
  const draco::PointAttribute* col = pc->GetNamedAttribute(draco::GeometryAttribute::COLOR);
  if (!pos || !col) {
    *error = "draco: no position or colour attribute";
    return false;
  }
  positions->resize(3 * static_cast<size_t>(pc->num_points()));
  colors->resize(3 * static_cast<size_t>(pc->num_points()));
  for (draco::PointIndex i(0); i < pc->num_points(); ++i) {
    pos->ConvertValue<float>(pos->mapped_index(i), 3, positions->data() + 3 * i.value());
    col->ConvertValue<std::uint8_t>(col->mapped_index(i), 3, colors->data() + 3 * i.value());
  }
  return true;
}

}  // namespace rgbdcast::bench
