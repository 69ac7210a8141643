// The MPI backend: rank 0 serves run indices, the other ranks ask, run and report.

#include "multibond/sweep/mpi_backend.h"

#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <thread>

#ifdef MULTIBOND_HAVE_MPI
#include <mpi.h>
#endif

namespace multibond::sweep {

namespace {

[[maybe_unused]] constexpr int kTagResult = 1, kTagRun = 2;

template <class T>
void Put(std::string& s, const T& v) {
  s.append(reinterpret_cast<const char*>(&v), sizeof v);
}
template <class T>
T Get(const std::string& s, size_t& pos) {
  T v{};
  if (pos + sizeof v > s.size()) throw std::runtime_error("a truncated message between MPI ranks");
  std::memcpy(&v, s.data() + pos, sizeof v);
  pos += sizeof v;
  return v;
}

[[maybe_unused]] void Pause() { std::this_thread::sleep_for(std::chrono::microseconds(50)); }

}  // namespace

bool LaunchedByMpirun() { return std::getenv("OMPI_COMM_WORLD_SIZE") != nullptr || std::getenv("PMI_SIZE") != nullptr; }

int EnvironmentRank() {
  for (const char* name : {"OMPI_COMM_WORLD_RANK", "PMI_RANK"})
    if (const char* v = std::getenv(name)) return std::atoi(v);
  return 0;
}

std::string PackResult(const RunResult& r) {
  std::string s;
  Put<std::int64_t>(s, r.run);
  Put<std::uint8_t>(s, r.ok ? 1 : 0);
  Put<std::uint32_t>(s, static_cast<std::uint32_t>(r.values.size()));
  for (const double v : r.values) Put<double>(s, v);
  s += r.reason;
  return s;
}

RunResult UnpackResult(const std::string& bytes) {
  RunResult r;
  size_t pos = 0;
  r.run = static_cast<long>(Get<std::int64_t>(bytes, pos));
  r.ok = Get<std::uint8_t>(bytes, pos) != 0;
  const auto n = Get<std::uint32_t>(bytes, pos);
  for (std::uint32_t i = 0; i < n; ++i) r.values.push_back(Get<double>(bytes, pos));
  r.reason = bytes.substr(pos);
  return r;
}

#ifdef MULTIBOND_HAVE_MPI

bool HaveMpi() { return true; }

std::string MpiVersion() {
  char text[MPI_MAX_LIBRARY_VERSION_STRING];
  int n = 0;
  MPI_Get_library_version(text, &n);
  std::string s(text, static_cast<size_t>(n));
  const size_t nl = s.find_first_of("\n,");
  return nl == std::string::npos ? s : s.substr(0, nl);
}

MpiSession::MpiSession() {
  int provided = 0;
  MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
}

MpiSession::~MpiSession() { MPI_Finalize(); }

void MpiSession::Abort(int code) const {
  MPI_Abort(MPI_COMM_WORLD, code);
  std::_Exit(code);  // MPI_Abort does not return; the compiler is not told so
}

void ServeRanks(const MpiSession& mpi, WorkQueue& queue, const std::function<void(const RunResult&)>& on_result,
                const std::atomic<bool>* stop) {
  int active = mpi.size() - 1;
  std::string buffer;
  while (active > 0) {
    if (stop && stop->load()) return;
    int flag = 0;
    MPI_Status status;
    MPI_Iprobe(MPI_ANY_SOURCE, kTagResult, MPI_COMM_WORLD, &flag, &status);
    if (!flag) {
      Pause();
      continue;
    }
    int count = 0;
    MPI_Get_count(&status, MPI_BYTE, &count);
    buffer.resize(static_cast<size_t>(count));
    MPI_Recv(buffer.data(), count, MPI_BYTE, status.MPI_SOURCE, kTagResult, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    if (count > 0) on_result(UnpackResult(buffer));
    const std::int64_t next = queue.Next(stop);
    MPI_Send(&next, 1, MPI_INT64_T, status.MPI_SOURCE, kTagRun, MPI_COMM_WORLD);
    if (next < 0) --active;
  }
}

void WorkForRankZero(const MpiSession&, const std::function<RunResult(long)>& run, const std::atomic<bool>* stop) {
  std::string message;  // the first request carries no result
  for (;;) {
    MPI_Send(message.data(), static_cast<int>(message.size()), MPI_BYTE, 0, kTagResult, MPI_COMM_WORLD);
    std::int64_t next = -1;
    MPI_Request request;
    MPI_Irecv(&next, 1, MPI_INT64_T, 0, kTagRun, MPI_COMM_WORLD, &request);
    for (int done = 0; !done;) {
      MPI_Test(&request, &done, MPI_STATUS_IGNORE);
      if (!done) {
        if (stop && stop->load()) {
          MPI_Cancel(&request);
          MPI_Request_free(&request);
          return;
        }
        Pause();
      }
    }
    if (next < 0) return;
    message = PackResult(run(static_cast<long>(next)));
  }
}

#else

bool HaveMpi() { return false; }
std::string MpiVersion() { return ""; }
MpiSession::MpiSession() { throw std::runtime_error("this multibond was built without MPI (MULTIBOND_MPI): it cannot run under mpirun"); }
MpiSession::~MpiSession() = default;
void MpiSession::Abort(int code) const { std::_Exit(code); }
void ServeRanks(const MpiSession&, WorkQueue&, const std::function<void(const RunResult&)>&, const std::atomic<bool>*) {}
void WorkForRankZero(const MpiSession&, const std::function<RunResult(long)>&, const std::atomic<bool>*) {}

#endif

}  // namespace multibond::sweep
