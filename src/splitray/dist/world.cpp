#include "splitray/dist/world.hpp"

#include <chrono>
#include <climits>
#include <cstdint>
#include <cstdlib>
#include <string>

#if SPLITRAY_HAS_MPI
#include <mpi.h>
#endif

namespace splitray::dist {

namespace {

// The job's size as the launcher announces it (OpenMPI, MPICH/PMI), 0 without a launcher.
int launcher_size() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE"})
    if (const char* value = std::getenv(name)) return std::atoi(value);
  return 0;
}

struct Session {
  World world;
  bool initialised = false;  // world() has run
  bool mpi_started = false;  // ... and called MPI_Init (a launcher started the process)
  bool peers_done = false;
#if SPLITRAY_HAS_MPI
  ~Session() {
    int finalized = 0;
    MPI_Finalized(&finalized);
    if (mpi_started && !finalized) MPI_Finalize();
  }
#endif
};

Session& session() {
  static Session s;
  return s;
}

}  // namespace

bool mpi_built() {
#if SPLITRAY_HAS_MPI
  return true;
#else
  return false;
#endif
}

const World& world() {
  Session& s = session();
  if (s.initialised) return s.world;
  const int size = launcher_size();
#if SPLITRAY_HAS_MPI
  if (size > 0) {
    int provided = 0;
    // Only the main thread calls MPI; the renderer's worker threads never do.
    MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
    MPI_Comm_rank(MPI_COMM_WORLD, &s.world.rank);
    MPI_Comm_size(MPI_COMM_WORLD, &s.world.size);
    s.mpi_started = true;
  }
#else
  if (size > 1)
    throw Error("mpirun",
                "this splitray was built without MPI, so it cannot run as " + std::to_string(size) +
                    " processes; mpirun use needs OpenMPI at build time (scripts/install-deps.sh "
                    "installs libopenmpi-dev and openmpi-bin; then rebuild)");
#endif
  s.initialised = true;
  return s.world;
}

bool launched() { return launcher_size() > 0; }

void broadcast(std::string& bytes) {
  if (!world().distributed()) return;
#if SPLITRAY_HAS_MPI
  std::uint64_t length = bytes.size();
  MPI_Bcast(&length, sizeof length, MPI_BYTE, 0, MPI_COMM_WORLD);
  bytes.resize(length);
  MPI_Bcast(bytes.data(), static_cast<int>(length), MPI_BYTE, 0, MPI_COMM_WORLD);
#endif
}

void all_or_none(const std::function<void()>& setup) {
  std::exception_ptr failure;
  std::string message;
  try {
    setup();
  } catch (const std::exception& e) {
    failure = std::current_exception();
    message = e.what();
  }
  const World& w = world();
  if (!w.distributed()) {
    if (failure) std::rethrow_exception(failure);
    return;
  }
#if SPLITRAY_HAS_MPI
  const int mine = failure ? w.rank : INT_MAX;
  int first = INT_MAX;
  MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  if (first == INT_MAX) return;
  int length = static_cast<int>(message.size());
  MPI_Bcast(&length, 1, MPI_INT, first, MPI_COMM_WORLD);
  message.resize(static_cast<std::size_t>(length));
  MPI_Bcast(message.data(), length, MPI_CHAR, first, MPI_COMM_WORLD);
  throw JobError("rank " + std::to_string(first), message);
#endif
}

bool prints_error(const std::exception& error) {
  const Session& s = session();
  return !(s.initialised && s.world.rank != 0 && dynamic_cast<const JobError*>(&error));
}

void end_after_error(const std::exception& error) {
  const Session& s = session();
  if (!s.initialised || !s.world.distributed() || s.peers_done ||
      dynamic_cast<const JobError*>(&error))
    return;
#if SPLITRAY_HAS_MPI
  MPI_Abort(MPI_COMM_WORLD, 1);
#endif
}

void mark_peers_done() { session().peers_done = true; }

double now_s() {
#if SPLITRAY_HAS_MPI
  if (session().mpi_started) return MPI_Wtime();
#endif
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace splitray::dist
