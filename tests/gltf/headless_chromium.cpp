#include "tests/gltf/headless_chromium.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <chrono>
#include <filesystem>
#include <string_view>
#include <vector>

#include "base/stopwatch.h"
#include "tests/common/test_data.h"
#include "tests/gltf/static_http_server.h"

extern char** environ;

namespace rgbdcast::test {

std::string find_chromium() {
  for (const char* p : {"/usr/bin/chromium", "/usr/bin/chromium-headless-shell", "/usr/lib/chromium/chromium"})
    if (std::filesystem::exists(p)) return p;
  return "";
}

pid_t spawn_chromium(const std::vector<std::string>& args, const std::string& log, const std::string& tmp_dir) {
  std::vector<std::string> strings(args);
  const size_t first_env = strings.size();
  strings.push_back("TMPDIR=" + tmp_dir);
  for (char** e = environ; *e; ++e)
    if (std::string_view(*e).substr(0, 7) != "TMPDIR=") strings.emplace_back(*e);
  std::vector<char*> argv, envp;
  for (size_t i = 0; i < strings.size(); ++i) (i < first_env ? argv : envp).push_back(strings[i].data());
  argv.push_back(nullptr);
  envp.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  pid_t pid = -1;
  const int spawned = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  return spawned == 0 ? pid : -1;
}

PagePost run_tools_page(const std::string& chromium, const std::string& page_and_query,
                        const std::map<std::string, std::string>& files, const std::string& work_dir,
                        const std::string& tag, int width, int height, int timeout_ms,
                        const std::map<std::string, int>& forwards) {
  PagePost r;
  StaticHttpServer server(source_path("tools"));
  for (const auto& [url, file] : files) server.map(url, file);
  for (const auto& [prefix, port] : forwards) server.forward(prefix, port);
  if (!server.start()) {
    r.body = "the loopback HTTP server did not start";
    return r;
  }
  const std::string url = "http://127.0.0.1:" + std::to_string(server.port()) + "/" + page_and_query;
  const std::string profile = work_dir + "/chromium-profile-" + tag;
  r.log = work_dir + "/" + tag + "-chromium.log";
  std::vector<std::string> args = {chromium,
                                   "--headless",
                                   "--no-sandbox",
                                   "--disable-gpu",
                                   "--enable-unsafe-swiftshader",
                                   "--use-angle=swiftshader",
                                   "--no-first-run",
                                   "--disable-background-networking",
                                   "--disable-component-update",
                                   "--disable-sync",
                                   "--hide-scrollbars",
                                   "--user-data-dir=" + profile,
                                   "--window-size=" + std::to_string(width) + "," + std::to_string(height),
                                   url};
  const auto t0 = std::chrono::steady_clock::now();
  const pid_t pid = spawn_chromium(args, r.log, work_dir);
  if (pid < 0) {
    r.body = "cannot start " + chromium;
    return r;
  }
  const auto posted = server.wait_for_post({"/result", "/error"}, timeout_ms);
  r.ms = ms_since(t0);
  kill(pid, SIGTERM);
  int status = 0;
  waitpid(pid, &status, 0);
  remove_tree_quietly(profile);
  if (!posted) return r;
  r.reported = true;
  r.ok = posted->first == "/result";
  r.body = posted->second;
  return r;
}

}  // namespace rgbdcast::test
