#include "common/training/lookalikes.h"

#include <algorithm>
#include <cstdlib>
#include <limits>

#include "common/matching/evidence.h"
#include "common/matching/localiser.h"

namespace sceneloc {
namespace {

// Tour frames read from the tour at a time.
constexpr size_t kWindow = 64;

// The rival of tour frame `frame` from its localisation: of the verified candidates outside
// the held-out stretch, the one with the most weighted inliers above chance.
LookAlike RivalOf(const LocaliseResult& result, int frame, const MatchOptions& options) {
  LookAlike out;
  for (const CandidateEvidence& c : result.candidates) {
    const float excess =
        static_cast<float>(VerifiedScore(c, options) - options.verify_chance_inliers);
    if (std::abs(c.location - frame) <= kHeldOutFrames) {
      out.own = std::max(out.own, excess);
    } else if (excess > out.excess) {
      out.rival = c.location;
      out.excess = excess;
    }
  }
  return out;
}

}  // namespace

StatusOr<std::vector<LookAlike>> MeasureLookAlikes(
    const TourFeatures& tour, const Map& map, ThreadPool* pool,
    const std::function<void(size_t done, size_t total)>& progress) {
  const MatchOptions options;  // the shipped settings
  std::vector<LookAlike> out(tour.size());
  for (size_t begin = 0; begin < tour.size(); begin += kWindow) {
    const size_t end = std::min(tour.size(), begin + kWindow);
    SCENELOC_ASSIGN_OR_RETURN(const TourWindow window, tour.Window(begin, end));
    for (size_t i = begin; i < end; ++i) {
      auto result = Localise(window[i], map, options, pool);
      if (!result.ok()) {
        return Status(result.status().code(), "look-alikes, tour image " + std::to_string(i) +
                                                  ": " + result.status().message());
      }
      if (!result->location_scores.empty()) {
        out[i] = RivalOf(*result, static_cast<int>(i), options);
      }
    }
    if (progress) progress(end, tour.size());
  }
  return out;
}

void StoreLookAlikes(const std::vector<LookAlike>& lookalikes, float min_excess, Map* map) {
  const size_t n = static_cast<size_t>(map->num_places());
  std::vector<std::vector<std::pair<uint32_t, float>>> of(n);
  for (size_t t = 0; t < lookalikes.size() && t < n; ++t) {
    const LookAlike& a = lookalikes[t];
    if (a.rival < 0 || static_cast<size_t>(a.rival) >= n || a.excess < min_excess || a.own <= 0) {
      continue;
    }
    const float ratio = std::min(1.0f, a.excess / a.own);
    of[t].emplace_back(static_cast<uint32_t>(a.rival), ratio);
    of[static_cast<size_t>(a.rival)].emplace_back(static_cast<uint32_t>(t), ratio);
  }
  // Each frame names only its best rival, so of three twins a place may be linked to one:
  // the look-alikes of a look-alike count too, at the product of the two ratios.
  const std::vector<std::vector<std::pair<uint32_t, float>>> direct = of;
  for (size_t t = 0; t < n; ++t) {
    for (const auto& [b, first] : direct[t]) {
      for (const auto& [c, second] : direct[b]) {
        if (std::abs(static_cast<int>(c) - static_cast<int>(t)) <= kHeldOutFrames) continue;
        of[t].emplace_back(c, first * second);
      }
    }
  }
  map->lookalike_offsets.assign(1, 0);
  map->lookalike_location.clear();
  map->lookalike_ratio.clear();
  for (auto& list : of) {
    // The strongest for each location, then the strongest locations, in tour order.
    std::sort(list.begin(), list.end(), [](const auto& a, const auto& b) {
      return a.first != b.first ? a.first < b.first : a.second > b.second;
    });
    list.erase(std::unique(list.begin(), list.end(),
                           [](const auto& a, const auto& b) { return a.first == b.first; }),
               list.end());
    if (list.size() > static_cast<size_t>(kMaxLookAlikes)) {
      std::stable_sort(list.begin(), list.end(),
                       [](const auto& a, const auto& b) { return a.second > b.second; });
      list.resize(kMaxLookAlikes);
      std::sort(list.begin(), list.end());
    }
    for (const auto& [location, ratio] : list) {
      map->lookalike_location.push_back(location);
      map->lookalike_ratio.push_back(ratio);
    }
    map->lookalike_offsets.push_back(static_cast<uint32_t>(map->lookalike_location.size()));
  }
}

std::vector<LookAlikeStretch> LookAlikeStretches(const std::vector<LookAlike>& lookalikes,
                                                 float min_excess) {
  std::vector<LookAlikeStretch> stretches;
  int last_rival = -1;  // the rival of the stretch's last frame
  for (size_t i = 0; i < lookalikes.size(); ++i) {
    const LookAlike& a = lookalikes[i];
    if (a.rival < 0 || a.excess < min_excess) continue;
    const int frame = static_cast<int>(i);
    if (!stretches.empty()) {
      LookAlikeStretch& s = stretches.back();
      // The rivals advance with the frames, either way along the route (a route that comes
      // back the other way), at about one location a frame.
      const int gap = frame - s.last;
      if (gap <= 2 && std::abs(a.rival - last_rival) <= gap + kHeldOutFrames) {
        s.last = frame;
        s.rival_first = std::min(s.rival_first, a.rival);
        s.rival_last = std::max(s.rival_last, a.rival);
        s.excess = std::max(s.excess, a.excess);
        last_rival = a.rival;
        continue;
      }
    }
    stretches.push_back({frame, frame, a.rival, a.rival, a.excess});
    last_rival = a.rival;
  }
  std::stable_sort(
      stretches.begin(), stretches.end(),
      [](const LookAlikeStretch& a, const LookAlikeStretch& b) { return a.excess > b.excess; });
  return stretches;
}

}  // namespace sceneloc
