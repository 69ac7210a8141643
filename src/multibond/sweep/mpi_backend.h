#pragma once
/// \file
/// A cluster: the same `multibond sweep` under `mpirun -n N` splits the runs over the ranks.
/// Rank 0 hands out run indices on request (dynamic load balancing: a rank asks for the next run
/// when it has sent the result of the last), keeps every result and writes every file; it runs
/// runs itself on worker threads meanwhile, while its main thread serves the other ranks (the
/// only thread that calls MPI: MPI_THREAD_FUNNELED). Waiting polls with short sleeps instead of
/// MPI's blocking calls, which spin: a rank that waits leaves its core to one that computes.
///
/// MPI is initialised only when the process was started by mpirun (its environment says so), so
/// that a plain `multibond sweep` does not pay for it. Built without MPI (MULTIBOND_MPI=OFF, or
/// not found), MpiSession throws.

#include <atomic>
#include <functional>
#include <string>

#include "multibond/sweep/runner.h"
#include "multibond/sweep/scheduler.h"

namespace multibond::sweep {

/// Whether the process was started by mpirun (Open MPI's OMPI_COMM_WORLD_SIZE, or PMI_SIZE).
bool LaunchedByMpirun();
/// This process's rank as mpirun's environment says it (0 when not started by mpirun).
int EnvironmentRank();
/// Whether this build has MPI.
bool HaveMpi();
/// "Open MPI v4.1.4, ..." (MPI_Get_library_version), "" without MPI.
std::string MpiVersion();

class MpiSession {
 public:
  /// MPI_Init_thread (funneled). Throws std::runtime_error without MPI.
  MpiSession();
  /// MPI_Finalize.
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
  int rank() const { return rank_; }
  int size() const { return size_; }
  /// Ends every rank of the job with `code` (MPI_Abort): after an error on rank 0, the other
  /// ranks would wait for it forever.
  [[noreturn]] void Abort(int code) const;

 private:
  int rank_ = 0, size_ = 1;
};

/// Rank 0: serves the runs of `queue` to ranks 1..size-1, handing each result received to
/// `on_result` (on this thread), until every rank has been told there are no more runs (or a stop
/// is asked for).
void ServeRanks(const MpiSession& mpi, WorkQueue& queue, const std::function<void(const RunResult&)>& on_result,
                const std::atomic<bool>* stop);
/// Ranks 1..size-1: asks rank 0 for runs and runs them (`run`), sending each result back, until
/// rank 0 says there are no more.
void WorkForRankZero(const MpiSession& mpi, const std::function<RunResult(long)>& run, const std::atomic<bool>* stop);

/// A result as bytes and back (the messages between ranks).
std::string PackResult(const RunResult& r);
RunResult UnpackResult(const std::string& bytes);

}  // namespace multibond::sweep
