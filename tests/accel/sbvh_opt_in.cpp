// Spatial splits are a compile-time opt-in (accel/sbvh.hpp). Compiled, not
// run, by tests/CMakeLists.txt (accel_sbvh_opt_in_*): with
// PRISM_TEST_WITH_SBVH it compiles; without it asking for spatial splits
// fails to compile, both with the builder (which only accel/sbvh.hpp
// names) and with a flag (which BVHBuildOptions::spatial_splits no longer
// takes: it holds the builder).
#include "prism/accel/scene_accel.hpp"
#if defined(PRISM_TEST_WITH_SBVH)
#include "prism/accel/sbvh.hpp"
#endif

int main() {
  prism::BVHBuildOptions opt;
#if defined(PRISM_TEST_AS_FLAG)
  opt.spatial_splits = true;
#else
  opt.spatial_splits = prism::spatial_split_builder;
#endif
  prism::MeshAccel accel(prism::TriangleMesh{}, opt);
  return accel.bounds().empty() ? 0 : 1;
}
