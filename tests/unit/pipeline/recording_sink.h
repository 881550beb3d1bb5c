// An IngestSink that records what a session reports, for the pipeline tests.
#pragma once

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <vector>

#include "core/pipeline/ingest_types.h"

namespace semmap::testing {

class RecordingSink final : public IngestSink {
 public:
  void OnStarted(const SessionInfo& s) override {
    std::lock_guard lock(mutex);
    started = s;
  }
  void OnAck(const FrameAckInfo& a) override {
    std::lock_guard lock(mutex);
    acks.push_back(a);
    done.notify_all();
  }
  void OnProgress(const IngestProgressInfo&) override {}
  void OnQueueRoom() override {}
  void OnFinished(const Status& s, const IngestSummaryInfo& summary) override {
    std::lock_guard lock(mutex);
    final_status = s;
    final_summary = summary;
    done.notify_all();
  }
  // The session acknowledged `n` frames (or finished first): false after 30 s.
  bool WaitForAcks(size_t n) {
    std::unique_lock lock(mutex);
    return done.wait_for(lock, std::chrono::seconds(30),
                         [&] { return acks.size() >= n || final_status.has_value(); });
  }
  Status Wait() {
    std::unique_lock lock(mutex);
    done.wait(lock, [&] { return final_status.has_value(); });
    return *final_status;
  }

  std::mutex mutex;
  std::condition_variable done;
  std::optional<SessionInfo> started;
  std::vector<FrameAckInfo> acks;
  std::optional<Status> final_status;
  IngestSummaryInfo final_summary;
};

}  // namespace semmap::testing
