// How evenly the ranks of a distributed render share an uneven scene, for
// the two ways of cutting the work (prism::mpi::Split): a grey floor and
// back wall under a square lamp, with a heap of glass spheres (many
// refractions a path, and caustics) in the top-left corner of the view only.
// Under mpirun, each split renders 3 times; rank 0 prints per run the wall
// time and the balance (slowest rank's render time over the ranks' mean: 1
// is perfect) and the best and worst over the runs.
// Usage: mpirun -np N mpi_balance_bench [width height spp threads_per_rank]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <vector>
#include <prism/render/mpi.hpp>

using namespace prism;

int main(int argc, char** argv) {
  mpi::Session session(&argc, &argv);
  int w = argc > 2 ? std::atoi(argv[1]) : 256, h = argc > 2 ? std::atoi(argv[2]) : 192;
  int spp = argc > 3 ? std::atoi(argv[3]) : 16, threads = argc > 4 ? std::atoi(argv[4]) : 1;
  return mpi::run_or_abort("mpi_balance_bench", [&] {
    Scene<RGB> scene;
    const uint32_t grey = scene.add_material(DiffuseMaterial{RGB(0.6f)});
    const uint32_t black = scene.add_material(DiffuseMaterial{RGB(0.f)});
    const uint32_t glass = scene.add_material(DielectricMaterial{IOR(1.5f), "glass"});
    TriangleMesh room;
    append_quad(room, {-4, 0, -4}, {0, 0, 8}, {8, 0, 0});  // floor, normal +y
    append_quad(room, {-4, 0, -2}, {8, 0, 0}, {0, 6, 0});  // back wall, normal +z
    scene.add_mesh_instance(std::move(room), grey);
    TriangleMesh lamp;
    append_quad(lamp, {-0.5f, 4, 0.5f}, {1, 0, 0}, {0, 0, 1});  // normal -y
    scene.add_mesh_instance(std::move(lamp), black, AreaEmission{RGB(12.f), 1, false});
    // The heap: nested and touching spheres where the camera's top-left corner looks.
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 3; ++j) {
        Point3f c{-2.2f + 0.35f * Float(i), 2.6f + 0.35f * Float(j), 0.f};
        scene.add_sphere(Sphere{c, 0.2f}, glass);
        scene.add_sphere(Sphere{c, 0.1f}, glass);
      }
    scene.build();
    PerspectiveCamera cam(look_at_camera_to_world({0, 2, 6}, {0, 2, 0}, {0, 1, 0}), radians(45), w, h);
    const int rank = mpi::rank();
    for (mpi::Split split : {mpi::Split::samples, mpi::Split::tiles}) {
      const char* name = split == mpi::Split::samples ? "samples" : "tiles";
      std::vector<double> balance, seconds;
      for (int run = 0; run < 3; ++run) {
        Film film(w, h);
        RenderOptions opt;
        opt.spp = spp;
        opt.seed = 1;
        opt.threads = threads;
        MPI_Barrier(MPI_COMM_WORLD);
        mpi::DistributedStats st = mpi::render(scene, cam, PathIntegrator{}, film, opt, split);
        if (rank == 0) {
          balance.push_back(st.imbalance());
          seconds.push_back(st.total.seconds);
          std::printf("mpi_balance_bench: %s split, run %d: %.3f s, rank times", name, run, st.total.seconds);
          for (const auto& r : st.ranks) std::printf(" %.3f", r.seconds);
          std::printf(", balance %.3f\n", st.imbalance());
        }
      }
      if (rank == 0)
        std::printf("mpi_balance_bench: %s split, %d ranks x %d threads, %dx%d %d spp: best %.3f s, balance %.3f-%.3f\n",
                    name, mpi::size(), threads, w, h, spp, *std::min_element(seconds.begin(), seconds.end()),
                    *std::min_element(balance.begin(), balance.end()),
                    *std::max_element(balance.begin(), balance.end()));
    }
    return 0;
  });
}
