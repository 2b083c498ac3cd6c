/* A fixed set of worker threads that run the slices of one frame in
 * parallel. The calling thread takes part, so a pool of n threads starts
 * n - 1 workers; they sleep on a condition variable between frames. Nothing
 * is allocated per run: the task is passed as a function pointer and a
 * context pointer. */
#pragma once

#include <condition_variable>
#include <cstddef>
#include <mutex>
#include <thread>
#include <vector>

namespace landmark {

/* Rows y0..y1-1 of slice i when height rows are cut into n slices:
 * boundaries fall on even rows (2x2-subsampled chroma rows are then never
 * shared by two slices), slices differ by at most two rows. */
void slice_rows (unsigned height, unsigned n, unsigned i, unsigned *y0,
    unsigned *y1);

class WorkerPool {
public:
  WorkerPool () = default;
  WorkerPool (const WorkerPool &) = delete;
  WorkerPool & operator= (const WorkerPool &) = delete;
  ~WorkerPool () { resize (1); }

  /* The name workers carry (at most 15 characters, Linux's limit). */
  static constexpr const char *kThreadName = "landmark-worker";

  /* The most threads a pool is given. */
  static constexpr unsigned kMaxThreads = 64;

  /* Threads that run() uses, the caller included (at least 1). Starting or
   * stopping workers happens here only, never in run(). */
  void resize (unsigned threads);
  unsigned threads () const { return (unsigned) workers_.size () + 1; }

  /* Calls f (i) for every i in 0..tasks-1, spread over the threads, and
   * returns when all calls have returned. f must not throw. */
  template < typename F > void run (unsigned tasks, F & f)
  {
    run_tasks (tasks, [](void *ctx, unsigned i) {
          (*static_cast < F * >(ctx)) (i);
        }, &f);
  }

  /* Slices a frame is cut into: one per thread alone, four per thread
   * otherwise, so that a thread delayed by another process leaves its
   * share to the others. */
  unsigned slices () const { return workers_.empty ()? 1 : 4 * threads (); }

  /* Calls f (slice, y0, y1) for the non-empty slices of rows 0..height-1
   * (slice_rows), in parallel. */
  template < typename F > void run_slices (unsigned height, F & f)
  {
    const unsigned n = slices ();
    auto task = [&](unsigned i) {
      unsigned y0, y1;
      slice_rows (height, n, i, &y0, &y1);
      if (y0 < y1)
        f (i, y0, y1);
    };
    run (n, task);
  }

  /* The number of processors the process may use. */
  static unsigned available_cores ();

private:
  using TaskFn = void (*) (void *ctx, unsigned index);
  void run_tasks (unsigned tasks, TaskFn fn, void *ctx);
  void work ();
  /* Takes and runs tasks until none is left; called with lock_ held. */
  void drain (std::unique_lock < std::mutex > &lock);

  std::vector < std::thread > workers_;
  std::mutex lock_;
  std::condition_variable wake_, done_;
  /* the current run, guarded by lock_ */
  TaskFn fn_ = nullptr;
  void *ctx_ = nullptr;
  unsigned tasks_ = 0, next_ = 0, unfinished_ = 0;
  unsigned long generation_ = 0;
  bool quit_ = false;
};

/* The threads for a frame of the given pixel count under an n-threads
 * setting: the setting itself (at most kMaxThreads), or for 0 every
 * available core on frames of 1920x1080 pixels and more, else one. */
unsigned frame_threads (unsigned setting, size_t pixels);

}  // namespace landmark
