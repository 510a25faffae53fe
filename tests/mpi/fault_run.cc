// `freeloc run --data D --out SUB.zip` (sift-essential, as the CLI resolves it) whose rank FREELOC_TEST_KILL_RANK
// ends itself with SIGKILL once its scenes are assigned, as a crashed node would — the fault half of
// tests/mpi/mpi_run_test.sh, kept out of the library and the CLI. Usage: fault_run --data D --out SUB.zip
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "freeloc/core/error.h"
#include "freeloc/core/logging.h"
#include "freeloc/pipeline/relocalizer.h"
#include "freeloc/pipeline/run_comm.h"
#include "freeloc/pipeline/run_controller.h"

int main(int argc, char** argv) {
  using namespace freeloc;
  SetLogLevel(LogLevel::kInfo);
  pipeline::RunSpec spec;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--data")) spec.data = argv[i + 1];
    if (!std::strcmp(argv[i], "--out")) spec.out = argv[i + 1];
  }
  spec.progress_bar = false;
  const char* kill = std::getenv("FREELOC_TEST_KILL_RANK");
  const int victim = kill ? std::atoi(kill) : -1;
  spec.on_assigned = [victim](const pipeline::RunComm& comm) {
    if (comm.rank() == victim) std::raise(SIGKILL);
  };
  const auto comm = pipeline::MpiCommFromEnvironment();
  try {
    pipeline::PipelineOptions o = pipeline::ResolvePreset("sift-essential");
    pipeline::FindModels(&o);
    o.Validate();
    pipeline::ExecuteRun(spec, o, nullptr, comm.get());
  } catch (const Error& e) {
    std::fprintf(stderr, "fault_run: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
