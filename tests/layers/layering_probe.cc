// Includes a header of common/map. Built twice (tests/layers/CMakeLists.txt): by a target that
// links sceneloc_map, which must compile, and by one that links only sceneloc_util, which
// must not: the map's headers are not on its include path.
#include "common/map/map.h"

namespace sceneloc {

int LayeringProbe() { return Map().num_images(); }

}  // namespace sceneloc
