#include "workerpool.h"

#include <algorithm>

#ifdef __linux__
#include <pthread.h>
#include <sched.h>
#endif

namespace landmark {

void
WorkerPool::resize (unsigned threads)
{
  const size_t want = std::max (threads, 1u) - 1;
  if (want == workers_.size ())
    return;
  {
    std::lock_guard < std::mutex > g (lock_);
    quit_ = true;
  }
  wake_.notify_all ();
  for (auto &t : workers_)
    t.join ();
  workers_.clear ();
  quit_ = false;
  workers_.reserve (want);
  for (size_t i = 0; i < want; i++) {
    workers_.emplace_back ([this] { work (); });
#ifdef __linux__
    /* a name for top -H, gdb and the tests */
    pthread_setname_np (workers_.back ().native_handle (), kThreadName);
#endif
  }
}

void
WorkerPool::drain (std::unique_lock < std::mutex > &lock)
{
  while (next_ < tasks_) {
    const unsigned i = next_++;
    const TaskFn fn = fn_;
    void *ctx = ctx_;
    lock.unlock ();
    fn (ctx, i);
    lock.lock ();
    if (--unfinished_ == 0)
      done_.notify_all ();
  }
}

void
WorkerPool::work ()
{
  std::unique_lock < std::mutex > lock (lock_);
  unsigned long seen = generation_;
  for (;;) {
    wake_.wait (lock, [&] { return quit_ || generation_ != seen; });
    if (quit_)
      return;
    seen = generation_;
    drain (lock);
  }
}

void
WorkerPool::run_tasks (unsigned tasks, TaskFn fn, void *ctx)
{
  if (tasks == 0)
    return;
  if (workers_.empty () || tasks == 1) {
    for (unsigned i = 0; i < tasks; i++)
      fn (ctx, i);
    return;
  }
  std::unique_lock < std::mutex > lock (lock_);
  fn_ = fn;
  ctx_ = ctx;
  tasks_ = tasks;
  next_ = 0;
  unfinished_ = tasks;
  generation_++;
  wake_.notify_all ();
  drain (lock);
  done_.wait (lock, [&] { return unfinished_ == 0; });
  fn_ = nullptr;
  ctx_ = nullptr;
}

unsigned
WorkerPool::available_cores ()
{
#ifdef __linux__
  cpu_set_t set;
  if (sched_getaffinity (0, sizeof (set), &set) == 0)
    return std::max (CPU_COUNT (&set), 1);
#endif
  return std::max (std::thread::hardware_concurrency (), 1u);
}

unsigned
frame_threads (unsigned setting, size_t pixels)
{
  if (setting == 0)
    setting = pixels >= (size_t) 1920 * 1080 ? WorkerPool::available_cores ()
        : 1;
  return std::min (setting, WorkerPool::kMaxThreads);
}

void
slice_rows (unsigned height, unsigned n, unsigned i, unsigned *y0,
    unsigned *y1)
{
  /* cut in row pairs; the last slice takes an odd last row */
  const unsigned pairs = (height + 1) / 2;
  n = std::max (n, 1u);
  *y0 = std::min (height, 2 * (unsigned) ((size_t) pairs * i / n));
  *y1 = std::min (height, 2 * (unsigned) ((size_t) pairs * (i + 1) / n));
}

}  // namespace landmark
