// TUM RGB-D image lists (rgb.txt, depth.txt) and the colour/depth association.
// Input: rgb.txt '\0' depth.txt.
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include "client/datasets/stamp_association.h"
#include "client/datasets/tum_dataset.h"
#include "common/time_util.h"
#include "tests/fuzz/fuzz_util.h"
#include "tests/testing/all_pairs_association.h"

namespace semmap {
namespace {

std::vector<int64_t> Stamps(const std::vector<TumListEntry>& entries) {
  std::vector<int64_t> stamps;
  for (const TumListEntry& e : entries) stamps.push_back(e.stamp_ns);
  return stamps;
}

// Checks a parsed list and that it re-serialises ("stamp path" lines) to the same entries.
void CheckList(const std::vector<TumListEntry>& entries, const std::string& name) {
  std::string text;
  int previous_line = 0;
  for (const TumListEntry& e : entries) {
    FUZZ_CHECK(!e.path.empty());
    FUZZ_CHECK(e.line > previous_line);
    previous_line = e.line;
    FUZZ_CHECK(e.stamp_ns >= -9'000'000'000'000'000'000LL &&
               e.stamp_ns <= 9'000'000'000'000'000'000LL);
    text += FormatStampSeconds(e.stamp_ns) + " " + e.path + "\n";
  }
  StatusOr<std::vector<TumListEntry>> again = ParseTumImageList(text, name);
  FUZZ_CHECK(again.ok());
  FUZZ_CHECK(again->size() == entries.size());
  for (size_t i = 0; i < entries.size(); ++i) {
    FUZZ_CHECK((*again)[i].path == entries[i].path);
    // FormatStampSeconds writes microseconds.
    FUZZ_CHECK(std::llabs((*again)[i].stamp_ns - entries[i].stamp_ns) <= 500);
  }
}

void CheckAssociation(const std::vector<int64_t>& a, const std::vector<int64_t>& b) {
  const std::vector<std::optional<size_t>> partner = AssociateStamps(a, b, kTumMaxAssociationNs);
  FUZZ_CHECK(partner.size() == a.size());
  std::vector<bool> used(b.size(), false);
  for (size_t i = 0; i < a.size(); ++i) {
    if (!partner[i]) continue;
    FUZZ_CHECK(*partner[i] < b.size());
    FUZZ_CHECK(!used[*partner[i]]);
    used[*partner[i]] = true;
    FUZZ_CHECK(std::llabs(a[i] - b[*partner[i]]) < kTumMaxAssociationNs);
  }
  if (a.size() * b.size() <= 4096)
    FUZZ_CHECK(partner == testing::AssociateAllPairs(a, b, kTumMaxAssociationNs));
}

}  // namespace
}  // namespace semmap

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace semmap;
  const std::vector<std::string_view> parts = fuzz::SplitParts(fuzz::AsText(data, size), 2);
  StatusOr<std::vector<TumListEntry>> rgb = ParseTumImageList(parts[0], "rgb.txt");
  StatusOr<std::vector<TumListEntry>> depth = ParseTumImageList(parts[1], "depth.txt");
  for (const auto& [list, name] : {std::pair{&rgb, "rgb.txt"}, std::pair{&depth, "depth.txt"}}) {
    if (list->ok()) {
      CheckList(**list, name);
    } else {
      FUZZ_CHECK(list->status().code() == StatusCode::kInvalidArgument);
      FUZZ_CHECK(fuzz::NamesSource(list->status().message(), std::string(name) + ":"));
    }
  }
  if (rgb.ok() && depth.ok()) CheckAssociation(Stamps(*rgb), Stamps(*depth));
  return 0;
}
