#pragma once
// How many threads a parallel stage of the reduction uses (OpenMP: normals, the organized outlier statistic; plain
// threads joined within the stage: the depth mesh's tiles, the realtime budget's JPEG and geometry encodes). Every
// parallel region passes this number explicitly (a num_threads clause, PCL's setNumberOfThreads, a worker count),
// so the cap is a value carried by ReductionParams::threads, not process-wide state.
namespace rgbdcast {

// requested > 0: that many. 0: OpenMP's default for the calling thread (omp_get_max_threads(): OMP_NUM_THREADS,
// else one per core). PCL's NormalEstimationOMP on its own takes omp_get_num_procs() and ignores OMP_NUM_THREADS,
// which is why it is given this number. Always >= 1 (1 when built without OpenMP).
int openmp_threads(int requested);

}  // namespace rgbdcast
