// The binding of the MuJoCo glue (mujoco/*.hpp): the callbacks' addresses, for ellipsim.mujoco to install
// in MuJoCo's hooks, the context they read, and the MuJoCo version the glue was compiled against.
#include "../mujoco/contact_filter.hpp"
#include "../mujoco/narrowphase.hpp"

#include "common.hpp"

namespace ellipsim::binding {

void bind_mujoco(nb::module_& m, nb::module_& t) {
  (void)t;
  using namespace nb::literals;
  nb::module_ g = m.def_submodule("mujoco", "ellipsim's MuJoCo callbacks, compiled against MuJoCo's headers.");
  g.attr("MUJOCO_VERSION") = mjVERSION_HEADER;  // the headers the glue was built against
  g.attr("FILTER") = reinterpret_cast<std::uintptr_t>(&glue::ellipsim_contact_filter);
  g.attr("NARROWPHASE") = reinterpret_cast<std::uintptr_t>(&glue::ellipsim_narrowphase);  // an mjfCollision
  g.def(
      "set_context",
      [](std::uintptr_t address) {
        glue::context_pointer().store(reinterpret_cast<const std::int64_t*>(address), std::memory_order_release);
      },
      "address"_a, "Point the callbacks at context.CONTEXT (an int64 array that lives as long as the process).");
}

}  // namespace ellipsim::binding
