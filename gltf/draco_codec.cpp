// The rgbdcast_draco shared library: Draco's mesh encoder and decoder behind std-only types (draco_codec.h).
#include "gltf/draco_codec.h"

#include <draco/attributes/attribute_quantization_transform.h>
#include <draco/compression/decode.h>
#include <draco/compression/expert_encode.h>
#include <draco/core/quantization_utils.h>
#include <draco/mesh/mesh.h>

#include <algorithm>
#include <exception>
#include <memory>

#define RGBDCAST_DRACO_EXPORT __attribute__((visibility("default")))

namespace rgbdcast::draco_codec {
namespace {

draco::DataType data_type_of(int component_type) {
  switch (component_type) {
    case 5120:
      return draco::DT_INT8;
    case 5121:
      return draco::DT_UINT8;
    case 5122:
      return draco::DT_INT16;
    case 5123:
      return draco::DT_UINT16;
    case 5125:
      return draco::DT_UINT32;
    case 5126:
      return draco::DT_FLOAT32;
    default:
      return draco::DT_INVALID;
  }
}

draco::GeometryAttribute::Type type_of(AttributeIn::Semantic s) {
  switch (s) {
    case AttributeIn::Semantic::kPosition:
      return draco::GeometryAttribute::POSITION;
    case AttributeIn::Semantic::kTexCoord:
      return draco::GeometryAttribute::TEX_COORD;
    case AttributeIn::Semantic::kColor:
      return draco::GeometryAttribute::COLOR;
    case AttributeIn::Semantic::kNormal:
      return draco::GeometryAttribute::NORMAL;
    default:
      return draco::GeometryAttribute::GENERIC;
  }
}

// Converts every point's value of `att` to T, tightly packed, into out.
template <class T>
bool convert_all(const draco::PointAttribute& att, size_t num_points, int components, std::vector<std::uint8_t>* out) {
  out->resize(num_points * components * sizeof(T));
  T* dst = reinterpret_cast<T*>(out->data());
  for (size_t i = 0; i < num_points; ++i) {
    const draco::AttributeValueIndex v = att.mapped_index(draco::PointIndex(static_cast<std::uint32_t>(i)));
    if (v.value() >= att.size()) return false;
    if (!att.ConvertValue<T>(v, static_cast<std::int8_t>(components), dst + i * components)) return false;
  }
  return true;
}

bool convert(const draco::PointAttribute& att, size_t num_points, const AttributeRequest& r,
             std::vector<std::uint8_t>* out) {
  switch (r.component_type) {
    case 5120:
      return convert_all<std::int8_t>(att, num_points, r.components, out);
    case 5121:
      return convert_all<std::uint8_t>(att, num_points, r.components, out);
    case 5122:
      return convert_all<std::int16_t>(att, num_points, r.components, out);
    case 5123:
      return convert_all<std::uint16_t>(att, num_points, r.components, out);
    case 5125:
      return convert_all<std::uint32_t>(att, num_points, r.components, out);
    case 5126:
      return convert_all<float>(att, num_points, r.components, out);
    default:
      return false;
  }
}

size_t component_bytes(int component_type) {
  switch (component_type) {
    case 5120:
    case 5121:
      return 1;
    case 5122:
    case 5123:
      return 2;
    default:
      return 4;
  }
}

}  // namespace

RGBDCAST_DRACO_EXPORT Encoded encode_mesh(const MeshIn& in, std::string* error) {
  Encoded result;
  try {
    if (in.num_points == 0 || in.num_indices == 0 || in.num_indices % 3 != 0 || in.num_points > 0x7fffffff) {
      *error = "draco: empty mesh or an index count that is not a multiple of 3";
      return result;
    }
    draco::Mesh mesh;
    mesh.set_num_points(static_cast<std::uint32_t>(in.num_points));
    mesh.SetNumFaces(in.num_indices / 3);
    for (size_t f = 0; f < in.num_indices / 3; ++f) {
      draco::Mesh::Face face;
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t i = in.indices[3 * f + k];
        if (i >= in.num_points) {
          *error = "draco: index out of range";
          return result;
        }
        face[k] = draco::PointIndex(i);
      }
      mesh.SetFace(draco::FaceIndex(static_cast<std::uint32_t>(f)), face);
    }
    std::vector<int> ids;
    for (const AttributeIn& a : in.attributes) {
      const draco::DataType dt = data_type_of(a.component_type);
      if (dt == draco::DT_INVALID || a.components < 1 || a.components > 4 || !a.data) {
        *error = "draco: unsupported attribute type";
        return result;
      }
      const size_t value_bytes = component_bytes(a.component_type) * a.components;
      draco::GeometryAttribute ga;
      ga.Init(type_of(a.semantic), nullptr, static_cast<std::uint8_t>(a.components), dt, a.normalized,
              static_cast<std::int64_t>(value_bytes), 0);
      const int id = mesh.AddAttribute(ga, true, static_cast<std::uint32_t>(in.num_points));
      if (id < 0) {
        *error = "draco: could not add an attribute";
        return result;
      }
      mesh.attribute(id)->buffer()->Write(0, a.data, value_bytes * in.num_points);
      ids.push_back(id);
    }
    draco::ExpertEncoder encoder(mesh);
    encoder.SetSpeedOptions(in.encode_speed, in.decode_speed);
    encoder.SetTrackEncodedProperties(true);
    for (size_t k = 0; k < in.attributes.size(); ++k)
      if (in.attributes[k].component_type == 5126 && in.attributes[k].quantization_bits > 0)
        encoder.SetAttributeQuantization(ids[k], in.attributes[k].quantization_bits);
    draco::EncoderBuffer buffer;
    const draco::Status st = encoder.EncodeToBuffer(&buffer);
    if (!st.ok()) {
      *error = std::string("draco: ") + st.error_msg();
      return result;
    }
    result.bytes.assign(buffer.data(), buffer.data() + buffer.size());
    for (int id : ids) result.attribute_ids.push_back(static_cast<int>(mesh.attribute(id)->unique_id()));
    result.num_points = encoder.num_encoded_points();
    result.num_faces = encoder.num_encoded_faces();
    result.decoded_min.resize(in.attributes.size());
    result.decoded_max.resize(in.attributes.size());
    for (size_t k = 0; k < in.attributes.size(); ++k) {
      const AttributeIn& a = in.attributes[k];
      if (a.semantic != AttributeIn::Semantic::kPosition || a.component_type != 5126 || a.quantization_bits <= 0)
        continue;
      const draco::PointAttribute& att = *mesh.attribute(ids[k]);
      draco::AttributeQuantizationTransform q;
      if (!q.ComputeParameters(att, a.quantization_bits)) continue;  // (the encoder failed on it already)
      const auto max_quantized = static_cast<std::int32_t>((1u << static_cast<std::uint32_t>(a.quantization_bits)) - 1);
      draco::Quantizer quantizer;
      draco::Dequantizer dequantizer;
      quantizer.Init(q.range(), max_quantized);
      if (!dequantizer.Init(q.range(), max_quantized)) continue;
      // The least values are the quantizer's origin (ComputeParameters found them); the largest are found here.
      std::vector<float> lo = q.min_values(), hi(a.components), v(a.components);
      att.GetValue(draco::AttributeValueIndex(0), hi.data());
      for (draco::AttributeValueIndex i(1); i < static_cast<std::uint32_t>(att.size()); ++i) {
        att.GetValue(i, v.data());
        for (int c = 0; c < a.components; ++c) hi[c] = std::max(hi[c], v[c]);
      }
      for (int c = 0; c < a.components; ++c) {
        const float origin = q.min_value(c);
        lo[c] = dequantizer.DequantizeFloat(quantizer.QuantizeFloat(lo[c] - origin)) + origin;
        hi[c] = dequantizer.DequantizeFloat(quantizer.QuantizeFloat(hi[c] - origin)) + origin;
      }
      result.decoded_min[k] = std::move(lo);
      result.decoded_max[k] = std::move(hi);
    }
  } catch (const std::exception& e) {
    *error = std::string("draco: ") + e.what();
    result = {};
  }
  return result;
}

RGBDCAST_DRACO_EXPORT bool decode_mesh(const std::uint8_t* data, size_t size,
                                       const std::vector<AttributeRequest>& requests, size_t max_points,
                                       size_t max_faces, Decoded* out, std::string* error) {
  try {
    draco::DecoderBuffer buffer;
    buffer.Init(reinterpret_cast<const char*>(data), size);
    auto type = draco::Decoder::GetEncodedGeometryType(&buffer);
    if (!type.ok() || type.value() != draco::TRIANGULAR_MESH) {
      *error = "not a Draco triangle mesh";
      return false;
    }
    draco::Decoder decoder;
    auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
    if (!decoded.ok()) {
      *error = std::string("Draco data does not decode: ") + decoded.status().error_msg();
      return false;
    }
    const std::unique_ptr<draco::Mesh> mesh = std::move(decoded).value();
    const size_t points = mesh->num_points(), faces = mesh->num_faces();
    if (points > max_points || faces > max_faces) {
      *error = "Draco mesh has " + std::to_string(points) + " points and " + std::to_string(faces) +
               " faces, more than declared";
      return false;
    }
    out->num_points = points;
    out->indices.resize(faces * 3);
    for (draco::FaceIndex f(0); f < mesh->num_faces(); ++f)
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t i = mesh->face(f)[k].value();
        if (i >= points) {
          *error = "Draco face index out of range";
          return false;
        }
        out->indices[3 * f.value() + k] = i;
      }
    out->attributes.assign(requests.size(), {});
    for (size_t r = 0; r < requests.size(); ++r) {
      const draco::PointAttribute* att =
          mesh->GetAttributeByUniqueId(static_cast<std::uint32_t>(requests[r].unique_id));
      if (!att || att->num_components() != requests[r].components) {
        *error = "Draco attribute " + std::to_string(requests[r].unique_id) + " is missing or has " +
                 (att ? std::to_string(att->num_components()) : std::string("no")) + " components";
        return false;
      }
      if (!convert(*att, points, requests[r], &out->attributes[r])) {
        *error = "Draco attribute " + std::to_string(requests[r].unique_id) + " does not convert";
        return false;
      }
    }
    return true;
  } catch (const std::exception& e) {
    *error = std::string("Draco decoder failed: ") + e.what();
    return false;
  }
}

}  // namespace rgbdcast::draco_codec
