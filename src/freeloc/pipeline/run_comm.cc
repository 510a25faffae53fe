#include "freeloc/pipeline/run_comm.h"

#include <csignal>
#include <cstdlib>
#include <list>
#include <string>
#include <vector>

#include "freeloc/core/error.h"

#ifdef FREELOC_WITH_MPI
#include <mpi.h>
#endif

namespace freeloc::pipeline {

namespace {
int EnvInt(const char* name) {
  const char* v = std::getenv(name);
  return v ? std::atoi(v) : 0;
}
}  // namespace

int LaunchedWorldSize() {
  // Open MPI's mpirun, MPICH/Hydra (and srun --mpi=pmi2), PMIx launchers (srun --mpi=pmix), plain srun.
  for (const char* var : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE"})
    if (EnvInt(var) > 0) return EnvInt(var);
  if (std::getenv("SLURM_PROCID") && EnvInt("SLURM_NTASKS") > 0) return EnvInt("SLURM_NTASKS");
  return 1;
}

#ifdef FREELOC_WITH_MPI

namespace {

class MpiComm : public RunComm {
 public:
  MpiComm() {
    int provided = 0;
    MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
  }
  ~MpiComm() override {
    for (auto& p : pending_) MPI_Wait(&p.request, MPI_STATUS_IGNORE);
    MPI_Finalize();
  }
  int rank() const override { return rank_; }
  int size() const override { return size_; }

  std::string Broadcast(const std::string& text) override {
    long long n = static_cast<long long>(text.size());
    MPI_Bcast(&n, 1, MPI_LONG_LONG, 0, MPI_COMM_WORLD);
    std::string out = rank_ == 0 ? text : std::string(static_cast<size_t>(n), '\0');
    if (n > 0) MPI_Bcast(out.data(), static_cast<int>(n), MPI_CHAR, 0, MPI_COMM_WORLD);
    return out;
  }

  void Send(int tag, const std::string& payload) override {
    FREELOC_CHECK(payload.size() < (1u << 31), "run: a scene record of " << payload.size() << " bytes is too large");
    pending_.push_back({payload, MPI_REQUEST_NULL});
    Pending& p = pending_.back();
    MPI_Isend(p.bytes.data(), static_cast<int>(p.bytes.size()), MPI_CHAR, 0, tag, MPI_COMM_WORLD, &p.request);
    // Forget the sends that completed.
    for (auto it = pending_.begin(); it != pending_.end();) {
      int done = 0;
      MPI_Test(&it->request, &done, MPI_STATUS_IGNORE);
      it = done ? pending_.erase(it) : std::next(it);
    }
  }

  bool Receive(bool wait, int* tag, std::string* payload, int* from) override {
    MPI_Status st;
    int flag = 1;
    if (wait) {
      MPI_Probe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &st);
    } else {
      MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &st);
      if (!flag) return false;
    }
    int n = 0;
    MPI_Get_count(&st, MPI_CHAR, &n);
    payload->assign(static_cast<size_t>(n), '\0');
    MPI_Recv(payload->data(), n, MPI_CHAR, st.MPI_SOURCE, st.MPI_TAG, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    *tag = st.MPI_TAG;
    *from = st.MPI_SOURCE;
    return true;
  }

  [[noreturn]] void Abort(int code) override {
    MPI_Abort(MPI_COMM_WORLD, code);
    std::_Exit(code);
  }

 private:
  struct Pending {
    std::string bytes;
    MPI_Request request;
  };
  int rank_ = 0, size_ = 1;
  std::list<Pending> pending_;  // list: the buffers must not move while a send is in flight
};

}  // namespace

std::unique_ptr<RunComm> MpiCommFromEnvironment() {
  if (LaunchedWorldSize() <= 1) return nullptr;
  return std::make_unique<MpiComm>();
}

#else

std::unique_ptr<RunComm> MpiCommFromEnvironment() {
  const int n = LaunchedWorldSize();
  FREELOC_CHECK(n <= 1, "run: launched as one of " << n
                                                   << " processes by an MPI launcher, but this freeloc was built "
                                                      "without MPI; each process would run the whole split. Install "
                                                      "libopenmpi-dev (scripts/install-deps.sh) and rebuild, or split "
                                                      "the run into shards and merge their submissions");
  return nullptr;
}

#endif

}  // namespace freeloc::pipeline
