// The cost of the fixed-order film reduction (prism::mpi::reduce_film) for a
// 4K film (3840x2160), under mpirun: every rank fills a film with samples and
// splats (as the default scene's caustic pass leaves them), then the films
// are reduced onto rank 0, 5 times. Rank 0 prints the best and median time
// and the rate in GB/s of film data received (64 bytes a pixel, 24 more with
// splats, from each other rank), and rank 0's CPU time in the reduction
// (which a loaded machine inflates less than the wall time).
// Usage: mpirun -np N mpi_reduce_bench [width height] [--no-splats]
#include <time.h>
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>
#include <prism/render/mpi.hpp>

namespace {
double cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}
}  // namespace

int main(int argc, char** argv) {
  prism::mpi::Session session(&argc, &argv);
  int w = 3840, h = 2160;
  bool splats = true;
  std::vector<const char*> pos;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--no-splats") == 0) splats = false;
    else pos.push_back(argv[i]);
  }
  if (pos.size() >= 2) {
    w = std::atoi(pos[0]);
    h = std::atoi(pos[1]);
  }
  const int rank = prism::mpi::rank(), ranks = prism::mpi::size();
  return prism::mpi::run_or_abort("mpi_reduce_bench", [&] {
    std::vector<double> times, cpu;
    for (int rep = 0; rep < 5; ++rep) {
      prism::Film film(w, h);
      film.prepare(prism::FilmEncoding::rgb);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) film.add_sample(x, y, prism::RGB(float(x % 7), float(y % 5), float(rank)), 1);
      if (splats) film.add_splats(std::vector<double>(size_t(w) * size_t(h) * 3, 0.25), 1.0);
      MPI_Barrier(MPI_COMM_WORLD);
      double c0 = cpu_seconds();
      double t = prism::mpi::reduce_film(film);
      cpu.push_back(cpu_seconds() - c0);
      double slowest = 0;
      MPI_Reduce(&t, &slowest, 1, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
      times.push_back(slowest);
      if (rank == 0 && film.sample_count(w - 1, h - 1) != uint64_t(ranks)) throw prism::Error("wrong sample count");
    }
    if (rank == 0) {
      std::sort(times.begin(), times.end());
      std::sort(cpu.begin(), cpu.end());
      double bytes = double(w) * double(h) * (sizeof(prism::Film::Pixel) + (splats ? 24.0 : 0.0)) * (ranks - 1);
      std::printf("mpi_reduce_bench: %dx%d film%s, %d ranks: %.1f MB received by rank 0; best %.3f s (%.2f GB/s), "
                  "median %.3f s (%.2f GB/s); rank 0 CPU time best %.3f s, median %.3f s\n",
                  w, h, splats ? " with splats" : "", ranks, bytes * 1e-6, times.front(), bytes / times.front() * 1e-9,
                  times[times.size() / 2], bytes / times[times.size() / 2] * 1e-9, cpu.front(), cpu[cpu.size() / 2]);
    }
    return 0;
  });
}
