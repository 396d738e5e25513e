// How a long-running process that handles one frame after another asks glibc to manage its
// heap: big per-request buffers (a SIFT pyramid, a scoring block) reused from the heap, and
// only very large ones (a full-size decode of a huge image) mapped and given back.
//
// Measured (docs/results.md, "Latency near the floor"): with glibc's defaults, or with
// every buffer of 1 MiB or more mapped and unmapped (the server's setting before issue
// 10), each request took its buffers as fresh pages from the kernel; on the 2-core VM that
// made plain SIFT on a 480x270 frame 75-110 ms instead of 20 ms.
#pragma once

namespace sceneloc {

// Allocations of 32 MiB or more are mapped (and returned to the system when freed); the
// heap keeps up to 64 MiB of free memory at its top instead of trimming it after every
// request. Call once, early in main, before other threads start.
void UseServingMallocPolicy();

}  // namespace sceneloc
