/* HARDSPHERE_GPU: one task at a time on a host thread of its own, for fix hardsphere's
   device step run ahead while LAMMPS integrates (FixHardSphere::end_of_step()).

   start() hands the worker a task and returns at once; wait() returns when it is done and
   throws what the task threw (as std::runtime_error with its message).  The worker starts on the
   first task and ends with the object.  Nothing of LAMMPS is touched here; the caller keeps the
   task's data alive and untouched until wait() returns. */
#ifndef HSGPU_STEP_AHEAD_H
#define HSGPU_STEP_AHEAD_H

#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>

class StepAhead {
 public:
  StepAhead() = default;
  StepAhead(const StepAhead &) = delete;
  StepAhead &operator=(const StepAhead &) = delete;

  ~StepAhead()
  {
    if (!worker.joinable()) return;
    {
      std::lock_guard<std::mutex> lock(m);
      quit = true;
    }
    cv.notify_all();
    worker.join();
  }

  /// Runs task on the worker; the previous task must have been waited for.
  void start(std::function<void()> task)
  {
    if (!worker.joinable()) worker = std::thread([this] { loop(); });
    {
      std::lock_guard<std::mutex> lock(m);
      job = std::move(task);
      pending = true;
      error.clear();
    }
    cv.notify_all();
  }

  /// Waits for the task started last (returns at once where there is none).
  void wait()
  {
    std::unique_lock<std::mutex> lock(m);
    cv.wait(lock, [this] { return !pending; });
    if (!error.empty()) {
      const std::string e = error;
      error.clear();
      throw std::runtime_error(e);
    }
  }

 private:
  std::thread worker;
  std::mutex m;
  std::condition_variable cv;
  std::function<void()> job;
  bool pending = false, quit = false;
  std::string error;

  void loop()
  {
    std::unique_lock<std::mutex> lock(m);
    while (true) {
      cv.wait(lock, [this] { return quit || (pending && job); });
      if (quit) return;
      std::function<void()> task = std::move(job);
      job = nullptr;
      lock.unlock();
      std::string what;
      try {
        task();
      } catch (std::exception &e) {
        what = e.what();
        if (what.empty()) what = "unknown error";
      } catch (...) {
        what = "unknown error";
      }
      lock.lock();
      error = what;
      pending = false;
      cv.notify_all();
    }
  }
};

#endif
