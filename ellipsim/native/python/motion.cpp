// The bindings of the core's motion/ folder.
#include "common.hpp"

namespace ellipsim::binding {

void bind_motion(nb::module_& m, nb::module_& t) {
  (void)m;
  (void)t;
}

}  // namespace ellipsim::binding
