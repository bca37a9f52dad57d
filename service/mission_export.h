#pragma once
// GET /v1/missions/{name}/model.glb?max-error=M: a bounded export of a mission from its tile hierarchy
// (service/mission_tiles.h), streamed from disk.
// - The cut: the coarsest tiles whose geometric error is at most M metres, by the tileset's REPLACE refinement (a tile
//   is taken when its error <= M, else its children are looked at); M = 0 takes the leaves: full detail.
// - The taken tile GLBs are merged without decoding (gltf/glb_merge.h) and streamed file by file with a
//   Content-Length: the service holds their JSON chunks, never the mission's geometry.
// - One committed tileset version is exported: its files are opened before the answer starts, so a newer commit
//   (which may delete them) does not cut a download short. The export follows the tileset, which lags the newest
//   keyframe by the background update (the "tileset" event says when it caught up); X-Tileset-Version names it.
// - Strong ETag of (tileset version, M): If-None-Match gives 304.
#include <optional>
#include <string>
#include <vector>

// Eigen (mission_tiles.h) before httplib.h: a macro of the headers httplib pulls in breaks Eigen's product kernels.
#include "scene/result.h"
#include "service/mission_tiles.h"
#include "service/http_reply.h"

namespace rgbdcast::service {

inline constexpr double kMaxExportErrorM = 10000.0;

// The tile file names (TileRecord::file()) of the cut at max_error_m of a 3D Tiles tileset whose content URIs are
// "tiles/<file>", in tileset order. kInvalidInput when the JSON is not such a tileset.
Result<std::vector<std::string>> tileset_cut(const std::string& tileset_json, double max_error_m);

// ?max-error=M: nullopt in *max_error_m when absent. Anything but one decimal number 0..kMaxExportErrorM is answered
// here (400 with a JSON body) and false returned.
bool read_max_error_param(const httplib::Request& req, httplib::Response& res, std::optional<double>* max_error_m);

// Answers the bounded export: 409 (Retry-After) when the mission has no committed tile yet, 503 when the tile files
// could not be opened, else 200 streaming the merged GLB (or 304).
void send_tile_model(const httplib::Request& req, httplib::Response& res, const MissionTiles& tiles,
                     const std::string& mission, double max_error_m);

}  // namespace rgbdcast::service
