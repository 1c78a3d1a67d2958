#include "splitray/dist/work_queue.hpp"

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <deque>
#include <list>
#include <optional>
#include <thread>

#include "splitray/dist/world.hpp"

#if SPLITRAY_HAS_MPI
#include <mpi.h>
#endif

namespace splitray::dist {

namespace {

struct Item {
  std::size_t begin = 0, end = 0, next = 0;  // units [begin, end), next to do (or to arrive)
};

// The first failed unit; later failures are not reported.
struct Failure {
  bool failed = false;
  std::size_t unit = 0;
  int rank = 0;
  std::string message;
  void record(std::size_t u, int r, std::string m) {
    if (failed) return;
    failed = true;
    unit = u;
    rank = r;
    message = std::move(m);
  }
};

// Hands out runs in order until the units end or a unit failed.
class Dispenser {
 public:
  Dispenser(const QueueOptions& options, const Failure& failure)
      : options_(options), failure_(failure) {}
  std::optional<Item> next() {
    if (failure_.failed || next_ >= options_.units) return std::nullopt;
    const std::size_t end =
        std::min(options_.units, next_ + std::max<std::size_t>(1, options_.run_length));
    const Item item{next_, end, next_};
    next_ = end;
    return item;
  }

 private:
  const QueueOptions& options_;
  const Failure& failure_;
  std::size_t next_ = 0;
};

class Stopwatch {
 public:
  explicit Stopwatch(double& total_ms) : total_(total_ms), start_(now_s()) {}
  ~Stopwatch() { total_ += (now_s() - start_) * 1e3; }

 private:
  double& total_;
  double start_;
};

std::string unit_name(const QueueOptions& options, std::size_t unit) {
  return options.name ? options.name(unit) : "unit " + std::to_string(unit);
}

[[noreturn]] void throw_failure(const QueueOptions& options, const Failure& failure) {
  throw JobError(unit_name(options, failure.unit) + " (rank " + std::to_string(failure.rank) + ")",
                 failure.message);
}

// One process: every unit in order, the same failure rule.
std::vector<RankStats> run_alone(
    const QueueOptions& options, const std::function<std::string(std::size_t)>& work,
    const std::function<void(std::size_t, int, std::string&&)>& collect) {
  RankStats stats;
  Failure failure;
  for (std::size_t unit = 0; unit < options.units && !failure.failed; ++unit) {
    try {
      std::string bytes;
      {
        const Stopwatch watch(stats.compute_ms);
        bytes = work(unit);
      }
      const Stopwatch watch(stats.collect_ms);
      collect(unit, 0, std::move(bytes));
      ++stats.units;
    } catch (const std::exception& e) {
      failure.record(unit, 0, e.what());
    }
  }
  if (failure.failed) throw_failure(options, failure);
  return {stats};
}

#if SPLITRAY_HAS_MPI
enum Tag : int { kWork = 1, kStop = 2, kResult = 3, kError = 4 };
constexpr auto kIdle = std::chrono::microseconds(100);  // a poll instead of MPI's busy wait
constexpr std::size_t kRunsInHand = 2;

std::string with_unit(std::size_t unit, std::string_view tail) {
  std::string bytes(sizeof(std::uint64_t) + tail.size(), '\0');
  const std::uint64_t u = unit;
  std::memcpy(bytes.data(), &u, sizeof u);
  std::memcpy(bytes.data() + sizeof u, tail.data(), tail.size());
  return bytes;
}

std::size_t unit_of(const std::string& bytes) {
  std::uint64_t u = 0;
  std::memcpy(&u, bytes.data(), std::min(bytes.size(), sizeof u));
  return u;
}

class Master {
 public:
  Master(const QueueOptions& options, const std::function<std::string(std::size_t)>& work,
         const std::function<void(std::size_t, int, std::string&&)>& collect, int size)
      : options_(options),
        work_(work),
        collect_(collect),
        dispenser_(options, failure_),
        ranks_(static_cast<std::size_t>(size)) {}

  RankStats run() {
    {
      const Stopwatch watch(stats_.comm_ms);
      for (int r = 1; r < static_cast<int>(ranks_.size()); ++r) top_up(r);
    }
    std::optional<Item> own;
    for (;;) {
      poll();
      if (!own || own->next == own->end) own = dispenser_.next();
      if (own) {
        work_own(own->next++);
        continue;
      }
      if (all_stopped() && receiving_.empty()) break;
      const Stopwatch watch(stats_.idle_ms);
      std::this_thread::sleep_for(kIdle);
    }
    if (failure_.failed) failed_ = true;
    return stats_;
  }
  bool failed() const { return failed_; }
  const Failure& failure() const { return failure_; }

 private:
  struct Peer {
    std::deque<Item> items;  // handed out, results not all announced
    bool stopped = false;
  };
  struct Receiving {
    MPI_Request request;
    std::string bytes;
    int rank, tag;
  };

  void work_own(std::size_t unit) {
    try {
      std::string bytes;
      {
        const Stopwatch watch(stats_.compute_ms);
        bytes = work_(unit);
      }
      ++stats_.units;
      const Stopwatch watch(stats_.collect_ms);
      collect_(unit, 0, std::move(bytes));
    } catch (const std::exception& e) {
      failure_.record(unit, 0, e.what());
    }
  }

  // Gives rank r runs until it holds kRunsInHand; stops it when it has none and none is left
  // (callers time it as communication).
  void top_up(int r) {
    Peer& peer = ranks_[static_cast<std::size_t>(r)];
    while (peer.items.size() < kRunsInHand) {
      const std::optional<Item> item = dispenser_.next();
      if (!item) break;
      const std::uint64_t range[2] = {item->begin, item->end};
      MPI_Send(range, sizeof range, MPI_BYTE, r, kWork, MPI_COMM_WORLD);
      peer.items.push_back(*item);
    }
    if (peer.items.empty() && !peer.stopped) {
      const char none = 0;
      MPI_Send(&none, 1, MPI_BYTE, r, kStop, MPI_COMM_WORLD);
      peer.stopped = true;
    }
  }

  // Matches the announced results (each names the sender's next unit: ranks work in order)
  // and hands out new runs at once; the bytes arrive later through the posted receives.
  void poll() {
    const double collect_before = stats_.collect_ms, start = now_s();
    receive();
    stats_.comm_ms += (now_s() - start) * 1e3 - (stats_.collect_ms - collect_before);
  }

  void receive() {
    for (;;) {
      int flag = 0;
      MPI_Message message;
      MPI_Status status;
      MPI_Improbe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &message, &status);
      if (!flag) break;
      int count = 0;
      MPI_Get_count(&status, MPI_BYTE, &count);
      Receiving& in = receiving_.emplace_back();
      in.rank = status.MPI_SOURCE;
      in.tag = status.MPI_TAG;
      in.bytes.resize(static_cast<std::size_t>(count));
      MPI_Imrecv(in.bytes.data(), count, MPI_BYTE, &message, &in.request);
      Peer& peer = ranks_[static_cast<std::size_t>(in.rank)];
      if (!peer.items.empty()) {
        Item& item = peer.items.front();
        // An error abandons the rest of its run.
        if (in.tag == kError || ++item.next == item.end) peer.items.pop_front();
      }
      top_up(in.rank);
    }
    for (auto it = receiving_.begin(); it != receiving_.end();) {
      int done = 0;
      MPI_Test(&it->request, &done, MPI_STATUS_IGNORE);
      if (!done) {
        ++it;
        continue;
      }
      const std::size_t unit = unit_of(it->bytes);
      if (it->tag == kError) {
        failure_.record(unit, it->rank, it->bytes.substr(sizeof(std::uint64_t)));
      } else {
        try {
          const Stopwatch collecting(stats_.collect_ms);
          collect_(unit, it->rank, it->bytes.substr(sizeof(std::uint64_t)));
        } catch (const std::exception& e) {
          failure_.record(unit, 0, e.what());
        }
      }
      it = receiving_.erase(it);
    }
  }

  bool all_stopped() const {
    for (std::size_t r = 1; r < ranks_.size(); ++r)
      if (!ranks_[r].stopped) return false;
    return true;
  }

  const QueueOptions& options_;
  const std::function<std::string(std::size_t)>& work_;
  const std::function<void(std::size_t, int, std::string&&)>& collect_;
  Failure failure_;
  Dispenser dispenser_;
  std::vector<Peer> ranks_;
  std::list<Receiving> receiving_;
  RankStats stats_;
  bool failed_ = false;
};

RankStats run_worker(const std::function<std::string(std::size_t)>& work) {
  RankStats stats;
  std::deque<Item> items;
  struct Sending {
    std::string bytes;
    MPI_Request request;
  };
  std::list<Sending> sending;
  bool stop = false;
  for (;;) {
    {
      const Stopwatch watch(stats.comm_ms);
      for (;;) {
        int flag = 0;
        MPI_Status status;
        MPI_Iprobe(0, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &status);
        if (!flag) break;
        std::uint64_t range[2] = {0, 0};
        MPI_Recv(range, sizeof range, MPI_BYTE, 0, status.MPI_TAG, MPI_COMM_WORLD,
                 MPI_STATUS_IGNORE);
        if (status.MPI_TAG == kStop)
          stop = true;
        else
          items.push_back(Item{range[0], range[1], range[0]});
      }
      for (auto it = sending.begin(); it != sending.end();) {
        int done = 0;
        MPI_Test(&it->request, &done, MPI_STATUS_IGNORE);
        it = done ? sending.erase(it) : std::next(it);
      }
    }
    if (!items.empty()) {
      Item& item = items.front();
      const std::size_t unit = item.next++;
      Sending& out = sending.emplace_back();
      int tag = kResult;
      try {
        std::string bytes;
        {
          const Stopwatch watch(stats.compute_ms);
          bytes = work(unit);
        }
        ++stats.units;
        const Stopwatch watch(stats.comm_ms);
        out.bytes = with_unit(unit, bytes);
      } catch (const std::exception& e) {
        out.bytes = with_unit(unit, e.what());
        tag = kError;
        item.next = item.end;  // the rest of the run is abandoned
      }
      if (item.next == item.end) items.pop_front();
      const Stopwatch watch(stats.comm_ms);
      MPI_Isend(out.bytes.data(), static_cast<int>(out.bytes.size()), MPI_BYTE, 0, tag,
                MPI_COMM_WORLD, &out.request);
      continue;
    }
    if (stop) break;
    const Stopwatch watch(stats.idle_ms);
    std::this_thread::sleep_for(kIdle);
  }
  const Stopwatch watch(stats.comm_ms);
  for (Sending& out : sending) MPI_Wait(&out.request, MPI_STATUS_IGNORE);
  return stats;
}
#endif

}  // namespace

std::vector<RankStats> run_queue(
    const QueueOptions& options, const std::function<std::string(std::size_t)>& work,
    const std::function<void(std::size_t, int, std::string&&)>& collect) {
  const World& w = world();
  if (!w.distributed()) return run_alone(options, work, collect);
#if SPLITRAY_HAS_MPI
  RankStats mine;
  std::optional<Master> master;
  if (w.rank == 0) {
    master.emplace(options, work, collect, w.size);
    mine = master->run();
  } else {
    mine = run_worker(work);
  }
  mine.rank = w.rank;
  std::vector<RankStats> all(static_cast<std::size_t>(w.size));
  MPI_Gather(&mine, sizeof mine, MPI_BYTE, all.data(), sizeof mine, MPI_BYTE, 0, MPI_COMM_WORLD);
  mark_peers_done();
  if (w.rank != 0) return {mine};
  if (master->failed()) throw_failure(options, master->failure());
  return all;
#else
  return run_alone(options, work, collect);
#endif
}

}  // namespace splitray::dist
