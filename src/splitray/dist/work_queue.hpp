#pragma once
// A work queue over the ranks of the job: rank 0 hands out runs of consecutive work units
// (tiles of an image, frames of an animation), works on units itself between handing them
// out, and receives every unit's result; the other ranks work on what they are given. Each
// rank keeps two runs in hand, so that it never waits for the next while rank 0 is busy.
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

namespace splitray::dist {

struct RankStats {
  int rank = 0;
  std::size_t units = 0;
  double compute_ms = 0;  // inside `work`
  double comm_ms = 0;     // inside MPI calls (sending, receiving, waiting for a transfer)
  double collect_ms = 0;  // rank 0: inside `collect` (assembly, writing outputs)
  double idle_ms = 0;     // waiting for work or for the others to finish
};

struct QueueOptions {
  std::size_t units = 0;
  std::size_t run_length = 1;  // consecutive units per hand-out
  // "tile 12", "frame 5": names the unit in the error of a failed one.
  std::function<std::string(std::size_t unit)> name;
};

// On every rank: `work(unit)` returns the unit's result as bytes. On rank 0 only:
// `collect(unit, rank, bytes)` receives each result (in completion order). A unit whose work
// or collect throws stops the hand-out; the runs already handed out finish, their results are
// collected, and then rank 0 throws Error("<name of the unit> (rank R)", message). The other
// ranks return normally. Returns every rank's statistics on rank 0 (rank order), its own on
// the others.
std::vector<RankStats> run_queue(
    const QueueOptions& options, const std::function<std::string(std::size_t unit)>& work,
    const std::function<void(std::size_t unit, int rank, std::string&& bytes)>& collect);

}  // namespace splitray::dist
