// Links prism::mpi from the installed package: its link interface must bring
// in MPI. Runs without mpirun, so it only shares out a render in one process.
#include <cstdio>
#include <prism/render/mpi.hpp>

#if !defined(PRISM_HAS_MPI) || PRISM_HAS_MPI != 1
#error "prism::mpi should define PRISM_HAS_MPI=1"
#endif

int main() {
  prism::RenderOptions opt;
  opt.spp = 5;
  int covered = 0;
  for (int r = 0; r < 3; ++r) {
    prism::RenderOptions s = prism::mpi::share(opt, prism::mpi::Split::samples, r, 3);
    if (s.first_sample != covered) return 1;
    covered += s.sample_count;
  }
  if (covered != 5) return 1;
  std::printf("prism::mpi consumer: ok (%s)\n", MPI_VERSION >= 3 ? "MPI 3 or later" : "MPI 2");
  return 0;
}
