#include "service/mission_export.h"

#include <cstdio>
#include <memory>

#include "gltf/glb_merge.h"
#include "service/view_params.h"  // parse_finite_double

namespace rgbdcast::service {
namespace {

using nlohmann::json;

Status cut_tile(const json& tile, double max_error_m, std::vector<std::string>* files) {
  if (!tile.is_object() || !tile.contains("geometricError") || !tile["geometricError"].is_number())
    return make_error(ErrorCode::kInvalidInput, "tileset: a tile without geometricError");
  const bool has_children = tile.contains("children") && tile["children"].is_array() && !tile["children"].empty();
  const bool has_content = tile.contains("content") && tile["content"].contains("uri");
  if (has_content && (tile["geometricError"].get<double>() <= max_error_m || !has_children)) {
    const std::string uri = tile["content"]["uri"].get<std::string>();
    if (uri.rfind("tiles/", 0) != 0)
      return make_error(ErrorCode::kInvalidInput, "tileset: a content uri outside tiles/");
    files->push_back(uri.substr(6));
    return ok_status();
  }
  if (has_children)
    for (const auto& child : tile["children"])
      if (auto st = cut_tile(child, max_error_m, files); !st) return st;
  return ok_status();
}

std::string error_text(double max_error_m) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", max_error_m);
  return text;
}

}  // namespace

Result<std::vector<std::string>> tileset_cut(const std::string& tileset_json, double max_error_m) {
  const json tileset = json::parse(tileset_json, nullptr, false);
  if (tileset.is_discarded() || !tileset.contains("root"))
    return make_error(ErrorCode::kInvalidInput, "tileset: no root");
  std::vector<std::string> files;
  if (auto st = cut_tile(tileset["root"], max_error_m, &files); !st) return st.error();
  return files;
}

bool read_max_error_param(const httplib::Request& req, httplib::Response& res, std::optional<double>* max_error_m) {
  *max_error_m = std::nullopt;
  if (!req.has_param("max-error")) return true;
  const std::string range = "a number of metres 0.." + error_text(kMaxExportErrorM);
  if (req.get_param_value_count("max-error") != 1) {
    send_error(res, 400, "max-error: given more than once");
    return false;
  }
  auto value = parse_finite_double("max-error", req.get_param_value("max-error"));
  if (!value || *value < 0.0 || *value > kMaxExportErrorM) {
    send_error(res, 400, "max-error: must be " + range + " (the largest geometric error of an exported tile)");
    return false;
  }
  *max_error_m = *value;
  return true;
}

void send_tile_model(const httplib::Request& req, httplib::Response& res, const MissionTiles& tiles,
                     const std::string& mission, double max_error_m) {
  // Two commits between the snapshot and the opening of its files can remove some of them: a fresh snapshot then.
  std::shared_ptr<const tiles::TilesetSnapshot> snapshot;
  std::vector<std::string> files;
  std::shared_ptr<glb::GlbFileMerge> merge;
  for (int attempt = 0; attempt < 3 && !merge; ++attempt) {
    snapshot = tiles.snapshot(mission);
    if (!snapshot || snapshot->tiles == 0) {
      res.set_header("Retry-After", "1");
      return send_error(res, 409,
                        "mission " + mission +
                            " has no tileset yet (it is built in the background after "
                            "each keyframe; the event stream reports 'tileset' when it is)");
    }
    auto cut = tileset_cut(snapshot->tileset_json, max_error_m);
    if (!cut) return send_error(res, cut.error());
    files = std::move(*cut);
    std::vector<std::string> paths;
    Result<std::unique_ptr<glb::GlbFileMerge>> opened = make_error(ErrorCode::kNotFound, "no tile");
    for (const auto& f : files) {
      auto path = tiles.tile_file(mission, f);
      if (!path) break;
      paths.push_back(*path);
    }
    if (paths.size() == files.size()) opened = glb::GlbFileMerge::open(paths);
    if (opened)
      merge = std::move(*opened);
    else if (opened.error().code != ErrorCode::kNotFound)
      return send_error(res, opened.error());
  }
  if (!merge) {
    res.set_header("Retry-After", "1");
    return send_error(res, 503, "the tileset of mission " + mission + " changed while it was opened; retry");
  }
  const std::string max_error = error_text(max_error_m);
  res.set_header("Cache-Control", "no-cache");
  res.set_header("X-Tileset-Version", std::to_string(snapshot->version));
  res.set_header("X-Tiles", std::to_string(files.size()));
  res.set_header("X-Max-Error", max_error);
  if (answer_not_modified(req, res,
                          "\"" + mission + "-v" + std::to_string(snapshot->version) + "-e" + max_error + "\""))
    return;
  res.status = 200;
  res.set_header("Content-Disposition", "attachment; filename=\"" + mission + "-e" + max_error + ".glb\"");
  const size_t size = merge->size();
  res.set_content_provider(size, "model/gltf-binary", [merge](size_t offset, size_t length, httplib::DataSink& sink) {
    std::vector<char> buffer(std::min<size_t>(length, 256u << 10));
    if (!merge->read(offset, buffer.data(), buffer.size())) return false;
    return sink.write(buffer.data(), buffer.size());
  });
}

}  // namespace rgbdcast::service
