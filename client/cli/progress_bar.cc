#include "client/cli/progress_bar.h"

#include <unistd.h>

#include <cstdio>

namespace semmap::cli {

ProgressBar::ProgressBar(uint64_t total, bool enabled)
    : total_(total),
      enabled_(enabled && ::isatty(STDERR_FILENO) != 0),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_ - std::chrono::seconds(1)) {}

void ProgressBar::Update(uint64_t done, const std::string& note) {
  last_done_ = done;
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (now - last_draw_ < std::chrono::milliseconds(100) && done < total_) return;
  last_draw_ = now;
  Draw(done, note);
}

void ProgressBar::Draw(uint64_t done, const std::string& note) {
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const double rate = elapsed > 0 ? done / elapsed : 0;
  const double eta = rate > 0 && total_ > done ? (total_ - done) / rate : 0;
  constexpr int kWidth = 30;
  const int filled = total_ ? static_cast<int>(kWidth * done / total_) : 0;
  std::string bar(filled, '#');
  bar.resize(kWidth, '.');
  std::fprintf(stderr, "\r[%s] %llu/%llu frames  %.1f fps  ETA %.0fs %s\033[K", bar.c_str(),
               static_cast<unsigned long long>(done), static_cast<unsigned long long>(total_), rate,
               eta, note.c_str());
  std::fflush(stderr);
}

void ProgressBar::Done() {
  if (!enabled_) return;
  Draw(last_done_, "");
  std::fprintf(stderr, "\n");
}

}  // namespace semmap::cli
