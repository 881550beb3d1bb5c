// What a transport (the gRPC reactor, a test) holds of a live ingest session: it feeds messages
// and ends the stream, but never owns the session. The IngestManager owns every session and
// destroys it on its own reaper thread once it has finished; from then on the handle's calls do
// nothing (TryEnqueue and HasRoom answer false), so a transport can outlive its session and a
// session's threads are never joined on a network thread.
#pragma once

#include "common/thread_annotations.h"
#include "core/pipeline/ingest_types.h"

namespace semmap {

class IngestSession;

class IngestSessionHandle {
 public:
  explicit IngestSessionHandle(IngestSession* session) : session_(session) {}
  IngestSessionHandle(const IngestSessionHandle&) = delete;
  IngestSessionHandle& operator=(const IngestSessionHandle&) = delete;

  // Never blocks. False when the queue is full (pause reading until IngestSink::OnQueueRoom)
  // or the session is gone.
  bool TryEnqueue(IngestMessage& message) SEMMAP_EXCLUDES(mutex_);
  bool HasRoom() SEMMAP_EXCLUDES(mutex_);
  // The client went away (or its deadline passed): the session stores what is queued, then
  // finishes with CANCELLED (or DEADLINE_EXCEEDED).
  void Cancel(bool deadline_passed = false) SEMMAP_EXCLUDES(mutex_);
  // The transport cannot go on (e.g. it could not queue a message): the session stores what is
  // queued and finishes with UNAVAILABLE.
  void Stop() SEMMAP_EXCLUDES(mutex_);

  // The owner, before it destroys the session: later calls do nothing.
  void Release() SEMMAP_EXCLUDES(mutex_);

 private:
  Mutex mutex_;
  IngestSession* session_ SEMMAP_GUARDED_BY(mutex_);
};

}  // namespace semmap
