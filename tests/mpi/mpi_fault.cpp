// A rank that fails stops the whole job (prism::mpi::run_or_abort), naming
// itself, while the other ranks wait for it. Run under mpirun with 2 ranks:
//   throw  rank 1 throws before a message that rank 0 waits for
//   film   rank 1 renders into a film of another size; rank 0 finds out in
//          the reduction and aborts
// Either way the job must end (the test's timeout proves it) with an error.
#include <cstdio>
#include <cstring>
#include <prism/prism.hpp>
#include <prism/render/mpi.hpp>

int main(int argc, char** argv) {
  prism::mpi::Session session(&argc, &argv);
  const char* mode = argc > 1 ? argv[1] : "throw";
  const int rank = prism::mpi::rank();
  return prism::mpi::run_or_abort("mpi_fault", [&] {
    if (prism::mpi::size() < 2) throw prism::Error("run with at least 2 ranks");
    if (std::strcmp(mode, "throw") == 0) {
      if (rank == 1) throw prism::Error("injected failure");
      int x = 0;
      MPI_Recv(&x, 1, MPI_INT, 1, 0, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      return 0;
    }
    prism::Scene<prism::RGB> scene;
    build_cornell_box(scene);
    scene.build();
    const int w = rank == 1 ? 8 : 16;
    prism::Film film(w, w);
    prism::RenderOptions opt;
    opt.spp = 2;
    opt.threads = 1;
    prism::mpi::render(scene, prism::default_camera(w, w), prism::PathIntegrator{}, film, opt);
    std::printf("rank %d: the reduction accepted films of different sizes\n", rank);
    return 0;
  });
}
