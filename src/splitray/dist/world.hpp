#pragma once
// The MPI job this process belongs to. MPI is started only when a launcher (mpirun) started
// the process, so the same binary runs as one process without it; mpi.h stays in dist/.
#include <exception>
#include <functional>
#include <string>

#include "splitray/core/errors.hpp"

namespace splitray::dist {

struct World {
  int rank = 0;  // this process, 0 = the one that hands out work and writes the outputs
  int size = 1;  // processes of the job
  bool distributed() const { return size > 1; }
};

// Whether this build has MPI (found by CMake).
bool mpi_built();
// The job: MPI initialised on first call when the process was started by mpirun (OpenMPI's
// or PMIx's environment), finalised at exit. Throws Error("mpirun", ...) when started by
// mpirun with more than one process in a build without MPI.
const World& world();
// Whether a launcher (mpirun) started this process, also as a job of one process.
bool launched();

// Rank 0's `bytes` on every rank (a no-op in one process).
void broadcast(std::string& bytes);

// Runs `setup` (load a scene, build its structure ...) on every rank and agrees on the
// outcome: when it threw on any rank, every rank throws an Error naming the first failed rank
// and its message, so that no rank waits for one that is gone.
void all_or_none(const std::function<void()>& setup);

// An error every rank of the job knows of (all_or_none, run_queue): rank 0 prints it, the
// job ends normally with a non-zero exit code.
class JobError : public Error {
 public:
  using Error::Error;
};

// For main's error path: whether this rank prints `error` (JobErrors on rank 0 only), and the
// end of the job: a rank that failed on its own while others may still wait for it ends
// the whole job (MPI_Abort), so that nothing hangs.
bool prints_error(const std::exception& error);
void end_after_error(const std::exception& error);
// Set by run_queue when every rank has left the queue: an error after it ends only this rank.
void mark_peers_done();

// Seconds since some fixed point (MPI_Wtime with MPI, steady clock without).
double now_s();

}  // namespace splitray::dist
