// The accuracy suite on big maps: every development set's map padded with distractor
// locations, so that its route is a small part of a map of the size users build (a campus
// of 20,000 locations). Each set's tour comes first, then look-alike places of another real
// building (the frames of the other data set, which the plain suite uses as frames from
// elsewhere), then generated distractors (e.g. `sceneloc-gentour --passes tour`) up to the
// map's size. Its queries are localised against that map as they are against the set's own
// (sceneloc-accuracy --distractors); frames of no map (e.g. a generated test pass of another
// seed) measure how often something off the route comes back LOCALISED.
//
// The big maps are trained streaming (trainer.h): the set's tour from the feature cache, the
// distractors' features spooled in the cache folder; each map is kept there too (one per
// tour, and the sets that share a tour share it). The paper's map and the baselines do not
// run (the paper's Q over 20,000 locations takes hours, the baselines' index holds every map
// feature); the set's own figures without distractors are the plain suite's.
#pragma once

#include <string>
#include <vector>

#include "common/training/trainer.h"
#include "tools/eval/accuracy_suite.h"

namespace sceneloc {

struct DistractorOptions {
  std::vector<std::string> generated;  // distractor images, in the order they pad the map
  int locations = 20000;               // every map's size (at least its set's tour)
  std::string offroute_dir;            // frames of no map ("" = none)
  ProgressFn progress;                 // training a padded map (may be empty)
};

// Trains (or reads from the cache) the padded map of `set`'s tour and runs its queries
// against it: ours, as a session, and the off-route frames. Errors: unreadable images or
// folders, fewer images than `locations` needs, a cache folder that cannot be written.
StatusOr<SetResult> RunSetWithDistractors(const SuiteSet& set, const SuiteSettings& settings,
                                          const SuiteContext& context,
                                          const DistractorOptions& distractors);

}  // namespace sceneloc
