// Proof that clang's thread-safety analysis rejects unguarded access (cmake/Warnings.cmake
// makes its findings errors). The file is built twice (tests/util/CMakeLists.txt):
//  - as thread_safety_control, in every build: the class below, used correctly, compiles;
//  - under clang, with SCENELOC_THREAD_SAFETY_VIOLATIONS defined, as the EXCLUDE_FROM_ALL
//    target thread_safety_violation, which the test util/ThreadSafetyAnalysisRejects
//    builds (expect_thread_safety_errors.cmake): it passes only when that build fails with
//    every error named by an `expect:` comment below.
#include <condition_variable>

#include "common/util/mutex.h"
#include "common/util/thread_annotations.h"

namespace sceneloc {

class Account {
 public:
  void Deposit(int amount) EXCLUDES(mutex_) {
    MutexLock lock(&mutex_);
    AddLocked(amount);
    changed_.notify_all();
  }

  // Waits until the balance covers `fee`, then takes it.
  void Charge(int fee) EXCLUDES(mutex_) {
    MutexLock lock(&mutex_);
    ++pending_;
    while (balance_ < fee) lock.Wait(changed_);
    balance_ -= fee;
    fees_ += fee;
    --pending_;
  }

  int TakeAll() EXCLUDES(mutex_) {
    MutexLock lock(&mutex_);
    const int taken = balance_;
    balance_ = 0;
    lock.Unlock();
    return taken;
  }

  int deposits() const EXCLUDES(mutex_) {
    MutexLock lock(&mutex_);
    return deposits_;
  }

#ifdef SCENELOC_THREAD_SAFETY_VIOLATIONS
  // A guarded member written without its mutex.
  void Reset() {
    balance_ = 0;  // expect: writing variable 'balance_' requires holding mutex 'mutex_'
  }

  // Read without its mutex.
  int Peek() const {
    return fees_;  // expect: reading variable 'fees_' requires holding mutex 'mutex_'
  }

  // A REQUIRES function called without the mutex.
  void Sneak() {
    AddLocked(1);  // expect: calling function 'AddLocked' requires holding mutex 'mutex_'
  }

  // Written after the scoped lock's early Unlock().
  void LateWrite() {
    MutexLock lock(&mutex_);
    lock.Unlock();
    ++deposits_;  // expect: writing variable 'deposits_' requires holding mutex 'mutex_'
  }

  // A lambda is a function of its own, which holds no lock even when called under one:
  // the reason wait loops are written out rather than given a predicate (mutex.h).
  void WaitWithPredicate() {
    MutexLock lock(&mutex_);
    const auto settled = [this] {
      return pending_ == 0;  // expect: reading variable 'pending_' requires holding mutex 'mutex_'
    };
    while (!settled()) lock.Wait(changed_);
  }
#endif

 private:
  void AddLocked(int amount) REQUIRES(mutex_) {
    balance_ += amount;
    ++deposits_;
  }

  mutable Mutex mutex_;
  std::condition_variable changed_;  // signalled when balance_ changes
  // Guarded by mutex_.
  int balance_ GUARDED_BY(mutex_) = 0;
  int fees_ GUARDED_BY(mutex_) = 0;
  int deposits_ GUARDED_BY(mutex_) = 0;
  int pending_ GUARDED_BY(mutex_) = 0;
};

// The correct uses, called (the violations need no call: clang analyses every function
// it compiles).
int UseAccount() {
  Account account;
  account.Deposit(2);
  account.Charge(1);
  return account.TakeAll() + account.deposits();
}

}  // namespace sceneloc
