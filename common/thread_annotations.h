// Clang thread-safety annotations (-Wthread-safety) and an annotated Mutex; empty on GCC.
//
// How to use (libstdc++'s std::mutex and std::lock_guard carry no annotations, so state that
// should be checked uses these):
//
//   class Counter {
//    public:
//     void Add() SEMMAP_EXCLUDES(mutex_) {
//       MutexLock lock(mutex_);
//       AddLocked();
//     }
//     void WaitPositive() {
//       MutexLock lock(mutex_);
//       while (count_ <= 0) changed_.wait(lock);  // not wait(lock, pred): lambdas are
//     }                                           // analysed without the lock
//    private:
//     void AddLocked() SEMMAP_REQUIRES(mutex_) { ++count_; changed_.notify_all(); }
//     mutable Mutex mutex_;
//     std::condition_variable_any changed_;  // waits on a MutexLock
//     int count_ SEMMAP_GUARDED_BY(mutex_) = 0;
//   };
//
// Every member a mutex protects gets SEMMAP_GUARDED_BY (SEMMAP_PT_GUARDED_BY for what a
// pointer member points to); a private helper called with the lock held gets SEMMAP_REQUIRES.
// SEMMAP_NO_THREAD_SAFETY_ANALYSIS is for the rare function the analysis cannot follow (say
// why next to it).
#pragma once

#include <mutex>

#if defined(__clang__)
#define SEMMAP_THREAD_ANNOTATION(x) __attribute__((x))
#else
#define SEMMAP_THREAD_ANNOTATION(x)
#endif

#define SEMMAP_CAPABILITY(name) SEMMAP_THREAD_ANNOTATION(capability(name))
#define SEMMAP_SCOPED_CAPABILITY SEMMAP_THREAD_ANNOTATION(scoped_lockable)
#define SEMMAP_GUARDED_BY(x) SEMMAP_THREAD_ANNOTATION(guarded_by(x))
#define SEMMAP_PT_GUARDED_BY(x) SEMMAP_THREAD_ANNOTATION(pt_guarded_by(x))
#define SEMMAP_REQUIRES(...) SEMMAP_THREAD_ANNOTATION(requires_capability(__VA_ARGS__))
#define SEMMAP_EXCLUDES(...) SEMMAP_THREAD_ANNOTATION(locks_excluded(__VA_ARGS__))
#define SEMMAP_ACQUIRE(...) SEMMAP_THREAD_ANNOTATION(acquire_capability(__VA_ARGS__))
#define SEMMAP_RELEASE(...) SEMMAP_THREAD_ANNOTATION(release_capability(__VA_ARGS__))
#define SEMMAP_TRY_ACQUIRE(...) SEMMAP_THREAD_ANNOTATION(try_acquire_capability(__VA_ARGS__))
#define SEMMAP_NO_THREAD_SAFETY_ANALYSIS SEMMAP_THREAD_ANNOTATION(no_thread_safety_analysis)

namespace semmap {

// std::mutex with annotations. BasicLockable and Lockable (lock, unlock, try_lock), so
// std::condition_variable_any and std::scoped_lock work with it too (unchecked, though: prefer
// MutexLock).
class SEMMAP_CAPABILITY("mutex") Mutex {
 public:
  Mutex() = default;
  Mutex(const Mutex&) = delete;
  Mutex& operator=(const Mutex&) = delete;

  void lock() SEMMAP_ACQUIRE() { mutex_.lock(); }
  void unlock() SEMMAP_RELEASE() { mutex_.unlock(); }
  bool try_lock() SEMMAP_TRY_ACQUIRE(true) { return mutex_.try_lock(); }

 private:
  std::mutex mutex_;
};

// Holds a Mutex for its scope (like std::unique_lock). lock()/unlock() let
// std::condition_variable_any wait on it, and let code drop the lock around a call.
class SEMMAP_SCOPED_CAPABILITY MutexLock {
 public:
  explicit MutexLock(Mutex& mutex) SEMMAP_ACQUIRE(mutex) : mutex_(mutex) { mutex_.lock(); }
  ~MutexLock() SEMMAP_RELEASE() {
    if (locked_) mutex_.unlock();
  }
  MutexLock(const MutexLock&) = delete;
  MutexLock& operator=(const MutexLock&) = delete;

  void lock() SEMMAP_ACQUIRE() {
    mutex_.lock();
    locked_ = true;
  }
  void unlock() SEMMAP_RELEASE() {
    mutex_.unlock();
    locked_ = false;
  }

 private:
  Mutex& mutex_;
  bool locked_ = true;
};

}  // namespace semmap
