// Clang's thread-safety attributes as macros, so that the compiler checks which mutex
// guards which member (https://clang.llvm.org/docs/ThreadSafetyAnalysis.html). Under any
// other compiler they expand to nothing.
//
// Use them with the annotated Mutex and MutexLock of common/util/mutex.h (libstdc++'s
// std::mutex carries no annotations):
//
//   class Counter {
//    public:
//     void Add() EXCLUDES(mutex_) { MutexLock lock(&mutex_); AddLocked(); }
//    private:
//     void AddLocked() REQUIRES(mutex_) { ++count_; }
//     Mutex mutex_;
//     int count_ GUARDED_BY(mutex_) = 0;
//   };
//
// A clang build (-Wthread-safety, an error in every clang build of sceneloc;
// cmake/Warnings.cmake) then rejects a read or write of count_ without mutex_ held, and a
// call of AddLocked() without it.
#pragma once

#if defined(__clang__)
#define SCENELOC_THREAD_ANNOTATION(x) __attribute__((x))
#else
#define SCENELOC_THREAD_ANNOTATION(x)
#endif

// On a class: its objects are capabilities (mutexes) named `x` in diagnostics.
#define CAPABILITY(x) SCENELOC_THREAD_ANNOTATION(capability(x))
// On an RAII class: holds a capability from construction to destruction.
#define SCOPED_CAPABILITY SCENELOC_THREAD_ANNOTATION(scoped_lockable)

// On a member: read or written only with mutex `x` held.
#define GUARDED_BY(x) SCENELOC_THREAD_ANNOTATION(guarded_by(x))
// On a pointer member: what it points to is read or written only with `x` held.
#define PT_GUARDED_BY(x) SCENELOC_THREAD_ANNOTATION(pt_guarded_by(x))

// On a mutex member: the order of acquisition (checked only with -Wthread-safety-beta).
#define ACQUIRED_BEFORE(...) SCENELOC_THREAD_ANNOTATION(acquired_before(__VA_ARGS__))
#define ACQUIRED_AFTER(...) SCENELOC_THREAD_ANNOTATION(acquired_after(__VA_ARGS__))

// On a function: the caller must hold the mutexes (exclusively / shared) and still holds
// them on return.
#define REQUIRES(...) SCENELOC_THREAD_ANNOTATION(requires_capability(__VA_ARGS__))
#define REQUIRES_SHARED(...) SCENELOC_THREAD_ANNOTATION(requires_shared_capability(__VA_ARGS__))

// On a function: it acquires the mutexes (held on return) / releases them (held on entry).
// Without an argument, on a member function of a capability class: `this`.
#define ACQUIRE(...) SCENELOC_THREAD_ANNOTATION(acquire_capability(__VA_ARGS__))
#define ACQUIRE_SHARED(...) SCENELOC_THREAD_ANNOTATION(acquire_shared_capability(__VA_ARGS__))
#define RELEASE(...) SCENELOC_THREAD_ANNOTATION(release_capability(__VA_ARGS__))
#define RELEASE_SHARED(...) SCENELOC_THREAD_ANNOTATION(release_shared_capability(__VA_ARGS__))
// On a function returning bool: it acquires the mutexes when it returns `result`.
#define TRY_ACQUIRE(...) SCENELOC_THREAD_ANNOTATION(try_acquire_capability(__VA_ARGS__))

// On a function: the caller must not hold the mutexes (the function takes them itself).
#define EXCLUDES(...) SCENELOC_THREAD_ANNOTATION(locks_excluded(__VA_ARGS__))

// On a function: asserts at run time that the mutex is held; the analysis trusts it.
#define ASSERT_CAPABILITY(x) SCENELOC_THREAD_ANNOTATION(assert_capability(x))

// On a function: it returns a reference to the mutex `x`.
#define RETURN_CAPABILITY(x) SCENELOC_THREAD_ANNOTATION(lock_returned(x))

// On a function: not analysed. Every use says in a comment why the analysis cannot follow.
#define NO_THREAD_SAFETY_ANALYSIS SCENELOC_THREAD_ANNOTATION(no_thread_safety_analysis)
