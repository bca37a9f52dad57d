#pragma once
// Opens a page of tools/ in headless Chromium (SwiftShader WebGL) and waits for the page to POST its result back to
// /result (or /error), for the browser tests. Served by a loopback StaticHttpServer with the given extra files.
#include <sys/types.h>

#include <map>
#include <optional>
#include <string>
#include <vector>

namespace rgbdcast::test {

// The installed Chromium binary, or "" when there is none.
std::string find_chromium();

struct PagePost {
  bool reported = false;  // false: the page sent nothing within the timeout (see log)
  bool ok = false;        // posted to /result (true) or /error (false)
  std::string body;       // what it posted
  double ms = 0.0;        // from launch to the post
  std::string log;        // Chromium's stdout+stderr file
};

// Starts args[0] (Chromium) with args, its stdout and stderr to `log` and its temporary files under tmp_dir (TMPDIR:
// the folder of its singleton socket, which an ended Chromium leaves in /tmp otherwise); its pid, or -1.
pid_t spawn_chromium(const std::vector<std::string>& args, const std::string& log, const std::string& tmp_dir);

// Serves tools/ plus `files` (URL path -> file), relays GETs under each prefix of `forwards` to that loopback port
// (StaticHttpServer::forward), opens tools/<page_and_query> at width x height with a fresh profile under work_dir,
// waits up to timeout_ms for the page's POST, then ends Chromium (by its pid) and removes the profile.
PagePost run_tools_page(const std::string& chromium, const std::string& page_and_query,
                        const std::map<std::string, std::string>& files, const std::string& work_dir,
                        const std::string& tag, int width, int height, int timeout_ms = 90000,
                        const std::map<std::string, int>& forwards = {});

}  // namespace rgbdcast::test
