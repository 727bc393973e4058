// The built-in default scene (build_cornell_box), built once per colour
// model and shared read-only by the tests of one executable.
#pragma once
#include <prism/prism.hpp>

namespace prism::test {

template <class S = RGB>
const Scene<S>& cornell_box() {
  static const Scene<S> scene = [] {
    Scene<S> s;
    build_cornell_box(s);
    s.build();
    return s;
  }();
  return scene;
}

}  // namespace prism::test
