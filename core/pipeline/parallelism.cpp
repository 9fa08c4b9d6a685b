#include "core/pipeline/parallelism.hpp"

#include <omp.h>

#include <algorithm>
#include <opencv2/core/utility.hpp>

namespace soilvol::pipeline {

void SetCallThreads(int threads) { omp_set_num_threads(std::max(1, threads)); }

void SetOpenCvThreads(int threads) { cv::setNumThreads(std::max(1, threads)); }

}  // namespace soilvol::pipeline
