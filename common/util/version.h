// The version of sceneloc a binary was built from: the project's version and, when built
// from a git checkout, the commit ("0.1.0+g1a2b3c4d5e", with "-dirty" after it when the
// tree had local changes). Every tool prints it for --version, the server logs it at start,
// and a map file records the version that trained it. Generated at build time
// (cmake/Version.cmake); CMake's SCENELOC_VERSION sets it where there is no .git (a
// package or image build from a source archive).
#pragma once

#include <string_view>

namespace sceneloc {

std::string_view Version();

}  // namespace sceneloc
