// `freeloc serve`: the relocalization service (service/server.h, docs/service.md). Bound to localhost unless told
// otherwise; SIGTERM or SIGINT stops it cleanly — the admitted requests are answered — and it exits 0.
#include <pthread.h>

#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdio>
#include <thread>

#include "freeloc/cli/commands.h"
#include "freeloc/core/error.h"
#include "freeloc/service/server.h"

namespace freeloc::cli {

namespace {

struct ServeArgs {
  PipelineArgs pipeline;
  service::ServiceOptions service;
};

int RunServe(const ServeArgs& a, const GlobalOptions& g) {
  service::ServiceOptions o = a.service;
  // Validated once, by the server.
  o.pipeline = ResolvePipelineArgs(
      a.pipeline, g, "sift-essential",
      [](pipeline::PipelineOptions* p) {
        FREELOC_OPTION_CHECK("matcher", !p->UsesPrecomputed(),
                             ": serve works on images: use sift, dust3r, dust3r+instances, mast3r or mast3r+instances");
      },
      /*validate=*/false);
  // SIGTERM/SIGINT go to one thread that stops the server (blocked here, before any thread starts, so every thread
  // inherits the mask).
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGTERM);
  sigaddset(&set, SIGINT);
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
  service::Server server(o);
  const int port = server.Bind();
  std::printf("freeloc serve: http://%s:%d/ (preset %s, %d workers)\n", o.host.c_str(), port, o.pipeline.preset.c_str(),
              o.workers);
  std::fflush(stdout);
  std::thread waiter([&] {
    int sig = 0;
    sigwait(&set, &sig);
    std::fprintf(stderr, "freeloc serve: %s, finishing the admitted requests\n", sig == SIGTERM ? "SIGTERM" : "SIGINT");
    server.Stop();
  });
  server.Serve();
  // Serve returned: stopped by the signal thread, or the listener failed; wake the waiter if it is still waiting.
  pthread_kill(waiter.native_handle(), SIGTERM);
  waiter.join();
  std::printf("freeloc serve: stopped\n");
  return 0;
}

}  // namespace

void RegisterServe(CLI::App& app, const GlobalOptions& global, RunFn* run) {
  auto a = std::make_shared<ServeArgs>();
  auto* sub = app.add_subcommand("serve", "Relocalization service: anchors kept warm, a JSON API and a web page");
  sub->add_option("--host", a->service.host, "address to listen on (localhost by default)")->capture_default_str();
  // Ranges as service::ServiceOptions::Validate checks them, here at parse (a usage error, and under --check-args).
  sub->add_option("--port", a->service.port, "port (0: any free one, printed)")
      ->capture_default_str()
      ->check(CLI::Range(0, 65535));
  sub->add_option("--workers", a->service.workers, "requests doing work at once")
      ->capture_default_str()
      ->check(CLI::Range(1, 256));
  sub->add_option("--max-queue", a->service.max_queue, "requests waiting for a worker; beyond: 503")
      ->capture_default_str()
      ->check(CLI::Range(0, 100000));
  sub->add_option("--max-upload-mb", a->service.max_upload_mb, "largest request body; beyond: 413")
      ->capture_default_str()
      ->check(CLI::Range(1, 4096));
  sub->add_option("--max-upload-mp", a->service.max_upload_mp,
                  "largest photo, in megapixels its header declares; beyond: 400 before decoding")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  sub->add_option("--max-anchors", a->service.max_anchors, "anchors held; beyond: 507")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000000));
  sub->add_option("--token", a->service.token, "require 'Authorization: Bearer TOKEN' on /v1 and /metrics")
      ->check(CLI::Validator(
          [](std::string& t) {
            return t.empty() ? std::string(
                                   "an empty token would let every client in: give a token, or leave "
                                   "--token out for a server without one")
                             : std::string();
          },
          "TOKEN"));
  sub->add_option("--store", a->service.store_dir, "persist anchors to this folder and reload them at start");
  AddPipelineArgs(sub, &a->pipeline, "sift-essential");
  sub->callback([a, run, &global] { *run = [a, &global] { return RunServe(*a, global); }; });
}

}  // namespace freeloc::cli
