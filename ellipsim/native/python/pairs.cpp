// The bindings of the core's pairs/ folder.
#include "common.hpp"

namespace ellipsim::binding {

void bind_pairs(nb::module_& m, nb::module_& t) {
  (void)m;
  (void)t;
}

}  // namespace ellipsim::binding
