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
#include "freeloc/service/service_fields.h"

namespace freeloc::cli {

namespace {

struct ServeArgs {
  PipelineArgs pipeline;
  std::map<std::string, std::string> service;  // the service family's fields as given (service/service_fields.h)
};

int RunServe(const ServeArgs& a, const GlobalOptions& g) {
  service::ServiceOptions o;
  for (const auto& [name, value] : a.service) service::SetServiceField(&o, name, value);
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
  // The service family's flags (service/service_fields.cc), each checked against its row's range as parsed.
  AddFamilyFlags(sub, service::ServiceFamily(), &a->service, [](const std::string& name, const std::string& value) {
    service::ServiceOptions scratch;
    service::SetServiceField(&scratch, name, value);
  });
  sub->get_option("--token")->check(CLI::Validator(
      [](std::string& t) {
        return t.empty() ? std::string(
                               "an empty token would let every client in: give a token, or leave "
                               "--token out for a server without one")
                         : std::string();
      },
      "TOKEN"));
  AddPipelineArgs(sub, &a->pipeline, "sift-essential");
  sub->callback([a, run, &global] { *run = [a, &global] { return RunServe(*a, global); }; });
}

}  // namespace freeloc::cli
