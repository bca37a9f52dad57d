// rgbdcast convert: one GLB in, the same scene out in another flavour (gltf/gltf_io.h): compact (meshopt +
// quantized, the wire format) or compat (plain floats and a JPEG, for Blender, Assimp and every viewer).
// Bad input gives one line on stderr and exit 2; the output is written atomically, so nothing is half-written.
#include <filesystem>
#include <iostream>

#include "app/cli_error.h"
#include "app/commands.h"
#include "base/atomic_file.h"
#include "gltf/gltf_io.h"

namespace rgbdcast::app {

namespace {

constexpr size_t kMaxInputBytes = size_t(1) << 30;  // decode_glb's own limit

struct ConvertArgs {
  std::string input, out;
  GlbWriteOptions glb = [] {
    GlbWriteOptions o;
    o.flavor = GlbFlavor::kCompat;
    return o;
  }();
};

[[noreturn]] void fail(const Error& e) { app::fail("convert", e); }

void run_convert(const ConvertArgs& a) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(a.input, ec))
    fail(make_error(ErrorCode::kNotFound, a.input + " is not a readable file"));
  auto bytes = read_file_bytes(a.input, kMaxInputBytes);
  if (!bytes) fail(bytes.error());
  GlbStats stats;
  auto out = convert_glb(bytes->data(), bytes->size(), a.glb, &stats);
  if (!out) fail(make_error(out.error().code, a.input + ": " + out.error().message));
  if (auto st = write_file_atomically(a.out, *out); !st) fail(st.error());
  std::cout << "rgbdcast convert: " << a.input << " (" << bytes->size() << " bytes) -> " << a.out << " ("
            << to_string(a.glb.flavor)
            << (a.glb.flavor == GlbFlavor::kCompact ? std::string(" ") + to_string(a.glb.geometry_codec) : "") << ", "
            << out->size() << " bytes: geometry " << stats.geometry_bytes << ", texture " << stats.texture_bytes << ", "
            << static_cast<int>(stats.ms) << " ms)\n";
}

}  // namespace

void register_convert(CLI::App& app) {
  auto args = std::make_shared<ConvertArgs>();
  CLI::App* cmd = app.add_subcommand("convert", "Re-encode a GLB in another flavour (compat opens in every viewer)");
  cmd->add_option("input", args->input, "Input GLB")->required();
  add_flavor_option(cmd, &args->glb, "compat");
  add_geometry_codec_option(cmd, &args->glb);
  cmd->add_option("--jpeg-quality", args->glb.jpeg_quality,
                  "JPEG quality 1..100 for PNG textures re-encoded for compat")
      ->capture_default_str();
  cmd->add_option("-o,--out", args->out, "Output GLB (written atomically)")->required();
  cmd->callback([args] { run_convert(*args); });
}

void add_flavor_option(CLI::App* cmd, GlbWriteOptions* glb, const std::string& default_name) {
  cmd->add_option_function<std::string>(
         "--flavor",
         [cmd, glb](const std::string& name) {
           auto f = parse_glb_flavor(name);
           if (!f) app::fail(cmd->get_name(), f.error());
           glb->flavor = *f;
         },
         "compact (meshopt + quantized: three.js, Babylon.js, Foxglove) or compat (plain floats, JPEG: Blender, "
         "Assimp, every viewer)")
      ->default_str(default_name);
}

void add_geometry_codec_option(CLI::App* cmd, GlbWriteOptions* glb, bool* chosen) {
  cmd->add_option_function<std::string>(
         "--geometry-codec",
         [cmd, glb, chosen](const std::string& name) {
           auto c = parse_geometry_codec(name);
           if (!c) app::fail(cmd->get_name(), c.error());
           glb->geometry_codec = *c;
           if (chosen) *chosen = true;
         },
         "compact flavour only: meshopt (EXT_meshopt_compression + KHR_mesh_quantization) or draco "
         "(KHR_draco_mesh_compression: about half the geometry bytes; three.js DRACOLoader)")
      ->default_str(chosen ? "the preset's: draco for realtime, meshopt for paper" : "meshopt");
}

}  // namespace rgbdcast::app
