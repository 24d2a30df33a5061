// _ellipsim: the Python binding of the C++ core, one file per folder of the core (exact.cpp,
// distance.cpp, pairs.cpp, motion.cpp; common.hpp their shared types).  Its source digest lets
// ellipsim.native refuse a module built from other sources.
#include <ellipsim/tolerances.hpp>

#include "common.hpp"

namespace {

// a * b + c as written: two roundings under the build's contract, one where a compiler fuses it.
double multiply_add(double a, double b, double c) { return a * b + c; }

}  // namespace

NB_MODULE(_ellipsim, m) {
  namespace nb = nanobind;
  using namespace nb::literals;
  namespace tol = ellipsim::tol;
  m.doc() = "ellipsim's compiled core (private: use the ellipsim package).";
  m.attr("SOURCE_DIGEST") = ELLIPSIM_SOURCE_DIGEST;
  nb::module_ t = m.def_submodule("testing", "Internal functions the tests reach (not an API).");
  ellipsim::binding::bind_exact(m, t);
  ellipsim::binding::bind_distance(m, t);
  ellipsim::binding::bind_pairs(m, t);
  ellipsim::binding::bind_pair_derivatives(m, t);
  ellipsim::binding::bind_motion(m, t);
  ellipsim::binding::bind_time_of_impact(m, t);
  ellipsim::binding::bind_mujoco(m, t);
  ellipsim::binding::bind_bench(m, t);
  ellipsim::binding::bind_cylinder(m, t);
  ellipsim::binding::bind_meshes(m, t);

  t.def("multiply_add", &multiply_add, "a"_a, "b"_a, "c"_a);
  nb::dict constants;  // every constant of tolerances.hpp (tests/test_native.py: the same as tolerances.py)
  constants["U"] = tol::U;
  constants["BOUNDING_INFLATION"] = tol::BOUNDING_INFLATION;
  constants["RATIO_MAX"] = tol::RATIO_MAX;
  constants["SCALE_MIN"] = tol::SCALE_MIN;
  constants["SCALE_MAX"] = tol::SCALE_MAX;
  constants["TAU"] = tol::TAU;
  constants["ERR_SHORT"] = tol::ERR_SHORT;
  constants["ERR_POLY"] = tol::ERR_POLY;
  constants["ERR_WITNESS"] = tol::ERR_WITNESS;
  constants["MU_MIN"] = tol::MU_MIN;
  constants["MU_MAX"] = tol::MU_MAX;
  constants["SUPPORT_SLACK"] = tol::SUPPORT_SLACK;
  constants["PW_MAX_ITER"] = tol::PW_MAX_ITER;
  constants["PW_RTOL"] = tol::PW_RTOL;
  constants["PW_TRY_SEPARATED"] = tol::PW_TRY_SEPARATED;
  constants["FILTER_CCD_FACTOR"] = tol::FILTER_CCD_FACTOR;
  constants["FILTER_RELATIVE_SLACK"] = tol::FILTER_RELATIVE_SLACK;
  constants["NEWTON_MAX_ITER"] = tol::NEWTON_MAX_ITER;
  constants["NEWTON_STEP_TOL"] = tol::NEWTON_STEP_TOL;
  constants["FIRST_RUN_ITER"] = tol::FIRST_RUN_ITER;
  constants["WARM_SIGMA_SLACK_ULPS"] = tol::WARM_SIGMA_SLACK_ULPS;
  constants["WARM_SCALE_MIN"] = tol::WARM_SCALE_MIN;
  constants["WARM_SCALE_MAX"] = tol::WARM_SCALE_MAX;
  constants["BB_TOL_REL"] = tol::BB_TOL_REL;
  constants["BB_TOL_ULPS"] = tol::BB_TOL_ULPS;
  constants["BB_ERR_SIGMA_ULPS"] = tol::BB_ERR_SIGMA_ULPS;
  constants["BB_PATCH_SLACK_ULPS"] = tol::BB_PATCH_SLACK_ULPS;
  constants["BB_FRAME_ULPS"] = tol::BB_FRAME_ULPS;
  constants["BB_MAX_PATCHES"] = tol::BB_MAX_PATCHES;
  constants["COAXIAL_MAX_NODES"] = tol::COAXIAL_MAX_NODES;
  constants["TILTED_MAX_NODES"] = tol::TILTED_MAX_NODES;
  constants["PARALLEL_CANDIDATE_TILT"] = tol::PARALLEL_CANDIDATE_TILT;
  constants["PAIR_CERT_REL"] = tol::PAIR_CERT_REL;
  constants["PAIR_SIGMA_SLACK_ULPS"] = tol::PAIR_SIGMA_SLACK_ULPS;
  constants["RIM_BB_NODES"] = tol::RIM_BB_NODES;
  constants["RIM_BB_LEVELS"] = tol::RIM_BB_LEVELS;
  constants["SECULAR_LAST"] = tol::SECULAR_LAST;
  constants["SECULAR_MAX_ITER"] = tol::SECULAR_MAX_ITER;
  constants["POLE_RTOL"] = tol::POLE_RTOL;
  constants["CRITICAL_MAX_ITER"] = tol::CRITICAL_MAX_ITER;
  constants["TOI_TOL"] = tol::TOI_TOL;
  constants["HALF_TURN_TOL"] = tol::HALF_TURN_TOL;
  constants["OMEGA_ZERO"] = tol::OMEGA_ZERO;
  constants["SINCOS_ERR"] = tol::SINCOS_ERR;
  constants["RODRIGUES_ERR"] = tol::RODRIGUES_ERR;
  constants["DELTA_R"] = tol::DELTA_R;
  constants["TOI_PROBE"] = tol::TOI_PROBE;
  constants["TOI_PROBE2"] = tol::TOI_PROBE2;
  constants["TOI_PROBE_REACH"] = tol::TOI_PROBE_REACH;
  constants["TOI_STALL"] = tol::TOI_STALL;
  constants["TOI_STALL_LIMIT"] = tol::TOI_STALL_LIMIT;
  constants["TOI_MAX_STEPS"] = tol::TOI_MAX_STEPS;
  constants["TOI_FALSI_STEPS"] = tol::TOI_FALSI_STEPS;
  constants["TOI_FALSI_RTOL"] = tol::TOI_FALSI_RTOL;
  constants["TOI_MAX_ORACLE"] = tol::TOI_MAX_ORACLE;
  constants["SMALL_BATCH_PAIRS"] = tol::SMALL_BATCH_PAIRS;
  constants["AXIS_SLACK"] = tol::AXIS_SLACK;
  constants["JACOBI_SWEEPS"] = tol::JACOBI_SWEEPS;
  constants["CONTAIN_NEWTON_STEPS"] = tol::CONTAIN_NEWTON_STEPS;
  constants["CONTAIN_RTOL"] = tol::CONTAIN_RTOL;
  constants["CONTAIN_RTOL_FINE"] = tol::CONTAIN_RTOL_FINE;
  constants["DERIV_FLAT_REL"] = tol::DERIV_FLAT_REL;
  constants["DERIV_POLISH_STEPS"] = tol::DERIV_POLISH_STEPS;
  constants["DERIV_POLISH_SLACK_ULPS"] = tol::DERIV_POLISH_SLACK_ULPS;
  constants["TOI_DERIV_NEWTON_STEPS"] = tol::TOI_DERIV_NEWTON_STEPS;
  constants["TOI_DERIV_NEWTON_TOL"] = tol::TOI_DERIV_NEWTON_TOL;
  constants["TOI_TRANSVERSAL_REL"] = tol::TOI_TRANSVERSAL_REL;
  constants["DERIV_KINK_COS"] = tol::DERIV_KINK_COS;
  constants["DERIV_KINK_REL"] = tol::DERIV_KINK_REL;
  t.attr("TOLERANCES") = constants;
}
