#pragma once
#include <time.h>

#include <chrono>

namespace splitray {

class Timer {
 public:
  Timer() : start_(std::chrono::steady_clock::now()) {}
  double ms() const {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_)
        .count();
  }
  void reset() { start_ = std::chrono::steady_clock::now(); }

 private:
  std::chrono::steady_clock::time_point start_;
};

// CPU time of the whole process (all threads): on a shared, loaded machine the CPU time of a
// single-threaded run is steadier than its wall time.
class CpuTimer {
 public:
  CpuTimer() : start_(now()) {}
  double ms() const { return now() - start_; }

 private:
  static double now() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) * 1e-6;
  }
  double start_;
};

}  // namespace splitray
