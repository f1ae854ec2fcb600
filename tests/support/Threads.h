#pragma once
/// @file Threads.h
/// @brief Test helper: OpenMP's thread count for a scope.

#ifdef _OPENMP
#include <omp.h>
#endif

namespace lsdem::test {

/// Sets OpenMP's thread count for its lifetime and restores the count it
/// found (nothing without OpenMP, where every run is on one thread).
class ScopedThreads {
 public:
  explicit ScopedThreads([[maybe_unused]] int threads) {
#ifdef _OPENMP
    omp_set_num_threads(threads);
#endif
  }
  ~ScopedThreads() {
#ifdef _OPENMP
    omp_set_num_threads(before_);
#endif
  }
  ScopedThreads(const ScopedThreads&) = delete;
  ScopedThreads& operator=(const ScopedThreads&) = delete;

 private:
#ifdef _OPENMP
  int before_ = omp_get_max_threads();
#endif
};

}  // namespace lsdem::test
