// prism/error.hpp — the one exception type prism throws (scene building and
// loading only; the render loop throws nothing). Its message names the file or
// object, the element and what is wrong.
#pragma once
#include <stdexcept>
#include <string>

namespace prism {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace prism
