// Long work off the UI thread: a Job runs one function on a worker thread; the UI polls it every
// frame (running? progress?), may ask it to stop, and takes the result once it is ready. A draw
// function never blocks on a job; only the snapshot renderer and shutdown Wait().
//
//   state.load_job.Start([path](JobControl& c) { ...; c.progress = 0.5f; ...; return result; });
//   ...every frame:
//   if (auto r = state.load_job.TakeIfReady()) Install(*r);
//
// The work must not throw (it returns errors as values); it reads `control.cancel` at convenient
// points and returns early when it is set.
#pragma once

#include <atomic>
#include <cassert>
#include <chrono>
#include <future>
#include <memory>
#include <optional>
#include <utility>

namespace gb::ui {

struct JobControl {
  std::atomic<bool> cancel{false};
  std::atomic<float> progress{0.0f};  // 0..1, for display only
};

template <class T>
class Job {
 public:
  Job() = default;
  Job(const Job&) = delete;
  Job& operator=(const Job&) = delete;
  ~Job() {
    RequestCancel();
    Wait();
  }

  // Starts `work(JobControl&) -> T`. Precondition: no job is under way (see active()).
  template <class F>
  void Start(F work) {
    assert(!active() && "Job::Start while the previous job is under way");
    control_ = std::make_shared<JobControl>();
    future_ = std::async(
        std::launch::async,
        [control = control_, work = std::move(work)]() mutable { return work(*control); });
  }

  // Started and its result not yet taken.
  bool active() const { return future_.valid(); }
  bool ready() const {
    return future_.valid() &&
           future_.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
  }
  float progress() const { return control_ ? control_->progress.load() : 0.0f; }
  void RequestCancel() {
    if (control_) control_->cancel = true;
  }
  void Wait() const {
    if (future_.valid()) future_.wait();
  }

  // The result, once: afterwards the job is idle again.
  std::optional<T> TakeIfReady() {
    if (!ready()) return std::nullopt;
    control_.reset();
    return future_.get();
  }

 private:
  std::shared_ptr<JobControl> control_;
  std::future<T> future_;
};

}  // namespace gb::ui
