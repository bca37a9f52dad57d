// Writes the seed corpora of fuzz/corpus/ (run once by hand when a format changes; the output is committed):
//   build-fuzz/fuzz/make_seeds fuzz/corpus
// Small valid inputs of every format, so that the fuzzers start past the signature checks.
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "gltf/glb_container.h"
#include "gltf/gltf_io.h"
#include "tests/gltf/hostile_glbs.h"
#include "tests/gltf/sample_scenes.h"

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;

namespace {

void write(const fs::path& path, const void* data, size_t n) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary).write(static_cast<const char*>(data), static_cast<std::streamsize>(n));
}
void write(const fs::path& path, const Bytes& b) { write(path, b.data(), b.size()); }
void write(const fs::path& path, const std::string& s) { write(path, s.data(), s.size()); }

Bytes encode(const std::string& ext, const cv::Mat& m) {
  std::vector<unsigned char> out;
  cv::imencode(ext, m, out);
  return out;
}

void put_u32(Bytes& b, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) b.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_seeds <corpus dir>\n");
    return 2;
  }
  const fs::path root = argv[1];
  using namespace rgbdcast;
  // GLB: what rgbdcast writes (plain, quantized, quantized + meshopt) and a points-only scene.
  GlbWriteOptions plain;
  plain.quantize = plain.meshopt = false;
  GlbWriteOptions quantized;
  quantized.meshopt = false;
  write(root / "glb" / "plain.glb", encode_glb(test::sample_scene(), plain).value());
  write(root / "glb" / "quantized.glb", encode_glb(test::sample_scene(), quantized).value());
  write(root / "glb" / "meshopt.glb", encode_glb(test::sample_scene(), GlbWriteOptions{}).value());
  GlbWriteOptions draco;
  draco.geometry_codec = GeometryCodec::kDraco;
  const Bytes draco_glb = encode_glb(test::sample_scene(), draco).value();
  write(root / "glb" / "draco.glb", draco_glb);
  // Draco: each Draco bitstream of that file, after its declared point count (fuzz_targets.h).
  {
    auto chunks = glb::parse_glb(draco_glb.data(), draco_glb.size()).value();
    const auto doc = nlohmann::json::parse(chunks.json);
    int k = 0;
    for (const auto& mesh : doc["meshes"])
      for (const auto& prim : mesh["primitives"]) {
        if (!prim.contains("extensions")) continue;
        const auto& view =
            doc["bufferViews"][prim["extensions"]["KHR_draco_mesh_compression"]["bufferView"].get<size_t>()];
        const size_t off = view.value("byteOffset", size_t(0)), len = view["byteLength"].get<size_t>();
        Bytes seed;
        put_u32(seed, doc["accessors"][prim["attributes"]["POSITION"].get<size_t>()]["count"].get<std::uint32_t>());
        seed.insert(seed.end(), chunks.bin.begin() + off, chunks.bin.begin() + off + len);
        write(root / "draco" / ("mesh" + std::to_string(k++) + ".bin"), seed);
      }
  }
  write(root / "glb" / "buffer_uri.glb", test::glb_with_buffer_uri("/etc/hostname"));
  write(root / "glb" / "nested_extras.glb", test::glb_with_nested_extras(70));

  // Images: 8-bit colour PNG/JPEG, grey PNG, 16-bit depth PNG, 32x24.
  cv::Mat bgr(24, 32, CV_8UC3), grey(24, 32, CV_8UC1), depth(24, 32, CV_16UC1);
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 32; ++x) {
      bgr.at<cv::Vec3b>(y, x) = cv::Vec3b(x * 8, y * 10, 128);
      grey.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(x * 8);
      depth.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>((x + y) % 7 == 0 ? 0 : 5000 + 40 * x + 30 * y);
    }
  const Bytes color_png = encode(".png", bgr), depth_png = encode(".png", depth);
  write(root / "frame_decode" / "color.png", color_png);
  write(root / "frame_decode" / "color.jpg", encode(".jpg", bgr));
  write(root / "frame_decode" / "grey.png", encode(".png", grey));
  write(root / "frame_decode" / "depth.png", depth_png);

  // Frame upload: u32 json length, u32 colour length, json, colour, depth.
  const std::string k = R"({"fx": 40.0, "fy": 40.0, "cx": 15.5, "cy": 11.5, "width": 32, "height": 24,
 "distortion": [0.2624, -0.9531, -0.0054, 0.0026, 1.1633], "depth_scale": 5000})";
  for (const auto& [name, colour] : {std::pair{"png", color_png}, std::pair{"jpg", encode(".jpg", bgr)}}) {
    Bytes b;
    put_u32(b, static_cast<std::uint32_t>(k.size()));
    put_u32(b, static_cast<std::uint32_t>(colour.size()));
    b.insert(b.end(), k.begin(), k.end());
    b.insert(b.end(), colour.begin(), colour.end());
    b.insert(b.end(), depth_png.begin(), depth_png.end());
    write(root / "frame_upload" / (std::string("frame_") + name), b);
  }

  // Intrinsics JSON: rgbdcast's own and Open3D's.
  write(root / "intrinsics" / "tum_fr1.json", k);
  write(
      root / "intrinsics" / "open3d.json",
      std::string(
          R"({"width": 640, "height": 480, "intrinsic_matrix": [525.0, 0.0, 0.0, 0.0, 525.0, 0.0, 319.5, 239.5, 1.0]})"));
  write(root / "intrinsics" / "minimal.json",
        std::string(R"({"fx": 1, "fy": 2, "cx": 3, "cy": 4, "width": 5, "height": 6})"));

  // PCD: a 4x3 organized x y z rgba cloud, in the three encodings PCL writes.
  pcl::PointCloud<pcl::PointXYZRGBA> cloud(4, 3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x) {
      auto& p = cloud.at(x, y);
      p.x = 0.1f * x;
      p.y = 0.1f * y;
      p.z = (x == 2 && y == 1) ? NAN : 1.0f + 0.05f * x;
      p.r = static_cast<std::uint8_t>(60 * x), p.g = static_cast<std::uint8_t>(80 * y), p.b = 10, p.a = 255;
    }
  fs::create_directories(root / "pcd");
  pcl::io::savePCDFileASCII((root / "pcd" / "ascii.pcd").string(), cloud);
  pcl::io::savePCDFileBinary((root / "pcd" / "binary.pcd").string(), cloud);
  pcl::io::savePCDFileBinaryCompressed((root / "pcd" / "binary_compressed.pcd").string(), cloud);

  // Trajectories: the first byte picks the format (0 TUM, 1 Redwood .log, 2 ICL-NUIM pose.txt).
  write(root / "trajectory" / "tum", std::string("\x00", 1) +
                                         "# timestamp tx ty tz qx qy qz qw\n"
                                         "1305031102.1758 1.3405 0.6266 1.6575 0.6574 0.6126 -0.2949 -0.3248\n"
                                         "1305031102.1858 1.3401 0.6261 1.6571 0.6575 0.6124 -0.2950 -0.3249\n");
  write(root / "trajectory" / "redwood", std::string("\x01", 1) +
                                             "0 0 1\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n"
                                             "1 1 2\n0.99 -0.01 0 0.1\n0.01 0.99 0 0\n0 0 1 0.02\n0 0 0 1\n");
  write(root / "trajectory" / "icl", std::string("\x02", 1) + "0 0 -2.25 0 0 0 1\n0.01 0 -2.25 0 0.0175 0 0.9998\n");

  // View queries (already percent-decoded, as cpp-httplib hands them over).
  write(root / "view_query" / "capture", std::string("pose=capture&width=640&height=480&format=jpeg&quality=85"));
  write(root / "view_query" / "lookat", std::string("eye=0,0,-1&target=0,0,1.5&up=0,-1,0&fov=60&format=png"));
  write(root / "view_query" / "points", std::string("pose=capture&mode=points&point_size=3&width=320&height=240"));
  std::printf("seeds written under %s\n", root.c_str());
  return 0;
}
