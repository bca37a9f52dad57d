// rgbdcast serve: the HTTP view service (service/view_service.h). Loopback unless --bind says otherwise; SIGINT or
// SIGTERM stop it cleanly: it drains (/readyz 503 for --drain-s), then in-flight requests finish; the store needs no
// cleanup (every write is atomic, or one transaction).
#include <pthread.h>
#include <signal.h>

#include <cctype>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <thread>

#include "app/cli_error.h"
#include "app/commands.h"
#include "service/view_service.h"

namespace rgbdcast::app {

void register_serve(CLI::App& app) {
  auto* cmd = app.add_subcommand("serve", "Serve scenes over HTTP: upload GLBs or RGB-D frames, get operator views");
  auto opts = std::make_shared<service::ServeOptions>();
  auto max_body_mib = std::make_shared<double>(64.0);
  auto backend = std::make_shared<std::string>("auto");
  auto imports = std::make_shared<std::vector<std::string>>();
  cmd->add_option("--data-dir", opts->data_dir, "Folder of the scene store (created when missing)")
      ->capture_default_str();
  cmd->add_option("--store", opts->store,
                  "Where scenes and missions live: \"directory\" (--data-dir) or a PostgreSQL URI "
                  "(postgresql://...) shared by replicas, tiles included; --data-dir then holds this replica's copy of "
                  "the tiles it served")
      ->default_str("directory");
  cmd->add_option("--replica", opts->replica, "This replica's name, sent as X-Rgbdcast-Replica (default: host name)");
  cmd->add_option("--drain-s", opts->drain_s,
                  "On SIGTERM: seconds /readyz answers 503 while requests are still served, before the stop")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 3600.0));
  cmd->add_option("--bind", opts->bind, "Address to listen on (0.0.0.0 for every interface)")->capture_default_str();
  cmd->add_option("--port", opts->port, "TCP port; 0 picks a free one")
      ->capture_default_str()
      ->check(CLI::Range(0, 65535));
  cmd->add_option("--threads", opts->threads, "HTTP worker threads")->capture_default_str()->check(CLI::Range(1, 1024));
  cmd->add_option("--max-body-mib", *max_body_mib, "Largest request body in MiB (larger: 413)")
      ->capture_default_str()
      ->check(CLI::Range(0.01, 4096.0));
  cmd->add_option("--backend", *backend, "Renderer backend")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "vulkan", "osmesa"}));
  cmd->add_option("--renderers", opts->renderers, "Renderer instances (views rendered at once)")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  cmd->add_option("--render-queue", opts->render_queue, "Views waiting for a renderer before 503")
      ->capture_default_str()
      ->check(CLI::Range(0, 100000));

  cmd->add_option("--reducers", opts->reducers, "Frame uploads reduced at once")
      ->capture_default_str()
      ->check(CLI::Range(1, 16));
  cmd->add_option("--reduce-threads", opts->reduce_threads,
                  "OpenMP threads per frame reduction; 0 = the cores divided among --reducers")
      ->capture_default_str()
      ->check(CLI::Range(0, 256));
  cmd->add_option("--reduce-queue", opts->reduce_queue, "Frame uploads waiting for a reducer before 503")
      ->capture_default_str()
      ->check(CLI::Range(0, 1000));
  cmd->add_option("--max-uploads", opts->max_uploads, "Request bodies received at once before 503")
      ->capture_default_str()
      ->check(CLI::Range(1, 256));
  auto max_frame = std::make_shared<std::string>("1920x1080");
  cmd->add_option("--max-frame", *max_frame, "Largest uploaded frame WIDTHxHEIGHT (checked before decoding)")
      ->capture_default_str();
  auto token_file = std::make_shared<std::string>();
  cmd->add_option("--token-file", *token_file,
                  "File holding the bearer token that POST and DELETE must carry (Authorization: Bearer <token>)")
      ->check(CLI::ExistingFile);
  cmd->add_flag("--insecure-no-auth", opts->insecure_no_auth,
                "Allow a non-loopback --bind without --token-file (anyone who reaches the port may write)");
  cmd->add_option("--allow-origin", opts->allow_origins,
                  "Origins (http://host:port) allowed besides the server's own; their host:port is accepted as Host");
  cmd->add_option("--header-timeout", opts->header_timeout_s, "Seconds a connection has to send its request headers")
      ->capture_default_str()
      ->check(CLI::Range(0.1, 300.0));
  cmd->add_option("--idle-timeout", opts->idle_timeout_s, "Seconds a keep-alive connection may stay idle")
      ->capture_default_str()
      ->check(CLI::Range(0.1, 3600.0));
  cmd->add_option("--max-connections", opts->max_connections, "Open connections before new ones get 503")
      ->capture_default_str()
      ->check(CLI::Range(1, 900));

  cmd->add_option("--resident-mb", opts->resident_mb,
                  "MiB of mission tiles and keyframes kept on the renderers, all together (least recently used go)")
      ->capture_default_str()
      ->check(CLI::Range(16, 1 << 20));
  cmd->add_option("--max-model-keyframes", opts->max_model_keyframes,
                  "Longest mission whose model.glb without max-error is assembled in memory; longer ones get 409 "
                  "and export from their tiles (?max-error=0: full detail, streamed from disk)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1 << 20));
  cmd->add_flag("!--keep-every-surface", opts->supersede,
                "Tiles keep every keyframe's whole surface (by default newer keyframes supersede the older surface "
                "they cover)");

  cmd->add_option("--max-event-streams", opts->max_event_streams,
                  "Mission event streams (SSE) open at once before 503; each holds an HTTP thread while open")
      ->capture_default_str()
      ->check(CLI::Range(0, 256));
  cmd->add_option("--event-stream-max-s", opts->event_stream_max_s,
                  "Seconds one event stream stays open; the browser then reconnects with Last-Event-ID")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 86400.0));
  cmd->add_option("--keep-alive-s", opts->keep_alive_s, "Seconds without an event before a keep-alive comment")
      ->capture_default_str()
      ->check(CLI::Range(0.1, 3600.0));

  cmd->add_option("--web-modules", opts->web_modules_dir,
                  "Folder of the operator page's npm modules (three.js, 3DTilesRendererJS); default: the source "
                  "tree's tools/node_modules. Without them the page shows server-rendered views")
      ->check(CLI::ExistingDirectory);

  cmd->add_option("--import", *imports, "GLB files to store at start (skipped when already stored)")
      ->check(CLI::ExistingFile);

  cmd->callback([opts, max_body_mib, backend, imports, max_frame, token_file] {
    opts->max_body_bytes = static_cast<size_t>(*max_body_mib * 1024.0 * 1024.0);
    if (std::sscanf(max_frame->c_str(), "%dx%d", &opts->max_frame_width, &opts->max_frame_height) != 2 ||
        opts->max_frame_width < 1 || opts->max_frame_height < 1 || opts->max_frame_width > 16384 ||
        opts->max_frame_height > 16384)
      fail("serve", make_error(ErrorCode::kInvalidArgument, "--max-frame must be WIDTHxHEIGHT, each 1..16384"));
    if (!token_file->empty()) {
      std::ifstream in(*token_file);
      std::string token((std::istreambuf_iterator<char>(in)), {});
      while (!token.empty() && std::isspace(static_cast<unsigned char>(token.back()))) token.pop_back();
      while (!token.empty() && std::isspace(static_cast<unsigned char>(token.front()))) token.erase(0, 1);
      if (token.size() < 16 || token.find_first_of(" \t\r\n") != std::string::npos)
        fail("serve", make_error(ErrorCode::kInvalidArgument,
                                 "--token-file must hold one token of at least 16 characters, without spaces"));
      opts->token = token;
    }
    opts->backend = *backend == "vulkan"   ? BackendChoice::kVulkan
                    : *backend == "osmesa" ? BackendChoice::kOsmesa
                                           : BackendChoice::kAuto;
    // Signals go to one thread that stops the server; every other thread (created below) inherits the mask.
    sigset_t signals;
    sigemptyset(&signals);
    sigaddset(&signals, SIGINT);
    sigaddset(&signals, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &signals, nullptr);

    auto created = service::ViewService::create(*opts);
    if (!created) fail("serve", created.error());
    auto& svc = *created;
    std::printf("rgbdcast serve: renderer %s (%s; %s)\n", svc->backend().c_str(), svc->device().c_str(),
                svc->backend_reason().c_str());
    const std::string base = svc->url();  // the address it is bound to, as given
    for (const auto& path : *imports) {
      auto imported = svc->import_glb_file(path);
      if (!imported) fail("serve", imported.error());
      const std::string id = (*imported)["id"];
      std::printf(
          "rgbdcast serve: %s is scene %s\n  view:  %s/v1/scenes/%s/view?pose=capture\n  model: "
          "%s/v1/scenes/%s/model.glb\n",
          path.c_str(), id.c_str(), base.c_str(), id.c_str(), base.c_str(), id.c_str());
    }
    const bool directory = opts->store.empty() || opts->store == "directory";
    std::printf("rgbdcast serve: replica %s, %zu scenes in %s\n", svc->replica().c_str(), svc->scene_count(),
                directory ? opts->data_dir.c_str() : "PostgreSQL");
    if (svc->web_modules_present())
      std::printf("rgbdcast serve: operator page renders in the browser (WebGL), modules from %s\n",
                  svc->web_modules_dir().c_str());
    else
      std::printf(
          "rgbdcast serve: no three.js modules in %s (npm ci in tools/): the operator page shows server-rendered "
          "views\n",
          svc->web_modules_dir().c_str());
    std::printf("rgbdcast serve: listening on %s/ (operator page), API under /v1/scenes\n", base.c_str());
    std::fflush(stdout);

    std::thread waiter([&svc, signals] {
      int sig = 0;
      sigwait(&signals, &sig);
      if (sig == SIGINT || sig == SIGTERM) svc->stop();
    });
    Status st = svc->run();
    // Wake the waiter if the server stopped for another reason.
    pthread_kill(waiter.native_handle(), SIGTERM);
    waiter.join();
    if (!st) fail("serve", st.error());
    std::printf("rgbdcast serve: stopped\n");
  });
}

}  // namespace rgbdcast::app
