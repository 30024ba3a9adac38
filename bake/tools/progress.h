// Progress display for long bake steps: nothing for steps under a second; then, on a
// terminal, one self-updating line with the elapsed time, and in a log (stderr not a
// terminal) one plain line per step that runs long.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <string>
#include <thread>

#include <unistd.h>

namespace skelform::tools {

class ProgressDisplay {
 public:
  explicit ProgressDisplay(bool enabled) : enabled_(enabled), terminal_(::isatty(STDERR_FILENO) != 0) {
    if (enabled_) worker_ = std::thread([this] { run(); });
  }
  ~ProgressDisplay() {
    if (!enabled_) return;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopping_ = true;
    }
    wake_.notify_all();
    worker_.join();
    if (terminal_ && shown_) std::fputs("\r\033[K", stderr);
  }
  ProgressDisplay(const ProgressDisplay&) = delete;
  ProgressDisplay& operator=(const ProgressDisplay&) = delete;

  // Starts a new step; the previous one ends.
  void step(const std::string& text) {
    if (!enabled_) return;
    std::lock_guard<std::mutex> lock(mutex_);
    text_ = text;
    started_ = std::chrono::steady_clock::now();
    announced_ = false;
  }

 private:
  void run() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (!stopping_) {
      wake_.wait_for(lock, std::chrono::milliseconds(200));
      if (stopping_ || text_.empty()) continue;
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
      if (seconds < 1.0) continue;
      if (terminal_) {
        std::fprintf(stderr, "\r\033[Kskelform-bake: %s (%.0f s)", text_.c_str(), seconds);
        std::fflush(stderr);
        shown_ = true;
      } else if (!announced_) {
        std::fprintf(stderr, "skelform-bake: %s ...\n", text_.c_str());
      }
      announced_ = true;
    }
  }

  const bool enabled_;
  const bool terminal_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::thread worker_;
  std::string text_;
  std::chrono::steady_clock::time_point started_;
  bool announced_ = false;
  bool shown_ = false;
  bool stopping_ = false;
};

}  // namespace skelform::tools
