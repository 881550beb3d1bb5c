#include "server/ingest/ingest_manager.h"

#include <algorithm>

namespace semmap {

IngestManager::IngestManager(StorageWriter* writer, IngestOptions options)
    : writer_(writer), options_(std::move(options)) {}

IngestManager::~IngestManager() {
  BeginShutdown();
  Join();
}

StatusOr<std::shared_ptr<IngestSession>> IngestManager::Open(std::shared_ptr<IngestSink> sink) {
  std::lock_guard lock(mutex_);
  if (shutting_down_) return UnavailableError("the server is shutting down");
  ReapFinishedLocked();
  auto session = std::make_shared<IngestSession>(std::move(sink), writer_, options_);
  sessions_.push_back(session);
  return session;
}

void IngestManager::BeginShutdown() {
  std::lock_guard lock(mutex_);
  shutting_down_ = true;
  for (auto& session : sessions_) session->Stop();
}

void IngestManager::Join() {
  std::vector<std::shared_ptr<IngestSession>> sessions;
  {
    std::lock_guard lock(mutex_);
    sessions.swap(sessions_);
  }
  // Destroying the last reference joins the worker; a reactor may still hold one briefly.
  sessions.clear();
}

size_t IngestManager::active_sessions() {
  std::lock_guard lock(mutex_);
  ReapFinishedLocked();
  return sessions_.size();
}

void IngestManager::ReapFinishedLocked() {
  sessions_.erase(std::remove_if(sessions_.begin(), sessions_.end(),
                                 [](const auto& s) { return s->finished(); }),
                  sessions_.end());
}

}  // namespace semmap
