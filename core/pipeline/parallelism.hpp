#pragma once

namespace soilvol::pipeline {

/// Threads the engine's OpenMP loops (outlier filter, ICP, surface fits) use for work the
/// calling thread starts from now on; each thread keeps its own setting. A server running N
/// calls at once on C CPUs bounds N x threads by a small multiple of C.
void SetCallThreads(int threads);

/// Threads OpenCV's parallel loops (stereo matching, rectification) use, for the whole
/// process; 1 runs them on the calling thread.
void SetOpenCvThreads(int threads);

}  // namespace soilvol::pipeline
