// How the processes of one distributed run talk (docs/architecture.md §3.3: the run controller's MPI ranks).
// ExecuteRun with a RunComm of size > 1 splits the scenes over the ranks (balanced by query count, deterministic);
// the ranks send each finished scene and a tick per query to rank 0, which journals, shows the one progress bar and
// writes the one submission — byte-identical to a single-process run. Light header; MPI stays in run_comm.cc.
#pragma once

#include <memory>
#include <string>

namespace freeloc::pipeline {

class RunComm {
 public:
  virtual ~RunComm() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;
  // Rank 0's `text` on every rank.
  virtual std::string Broadcast(const std::string& text) = 0;
  // To rank 0 (non-blocking; delivered before the rank finishes).
  virtual void Send(int tag, const std::string& payload) = 0;
  // Rank 0: the next message from any rank; waits when `wait`, else returns false when none is pending.
  virtual bool Receive(bool wait, int* tag, std::string* payload, int* from) = 0;
  // Ends every rank of the run with `code` (a rank that cannot go on must not leave the others waiting).
  [[noreturn]] virtual void Abort(int code) = 0;
};

// The world size an MPI launcher (mpirun/mpiexec of Open MPI or MPICH, srun) gave this process; 1 when not launched
// by one.
int LaunchedWorldSize();

// The MPI communicator of this run when launched by an MPI launcher with more than one process (MPI initialised
// here, finalised when the object dies); nullptr otherwise. Throws freeloc::Error when launched by one but this
// build has no MPI — N copies would each run the whole split.
std::unique_ptr<RunComm> MpiCommFromEnvironment();

}  // namespace freeloc::pipeline
