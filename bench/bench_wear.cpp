// Wall time of one blue-loop step (wear + pitting increment, then the new contact force) on one
// core, for both force models, at the thesis's operating points. Target: far below one record
// interval (the model thread must keep up with one record per minute).
#include <chrono>
#include <cstdio>

#include "gearwatch/wear/wear_loop.hpp"

int main() {
  using namespace gearwatch;
  struct Case {
    const char* name;
    wear::ForceModel model;
    double speed, torque, k_seed;
  };
  for (const Case c : {Case{"quasi-static", wear::ForceModel::quasi_static, 10.0, 5.0, 1.65e-6},
                       Case{"quasi-static", wear::ForceModel::quasi_static, 20.0, 20.0, 3.55e-10},
                       Case{"dynamic 21-DOF", wear::ForceModel::dynamic, 10.0, 5.0, 1.65e-6},
                       Case{"dynamic 21-DOF", wear::ForceModel::dynamic, 20.0, 20.0, 3.55e-10}}) {
    wear::WearLoopOptions o;
    o.k_wear_si = wear::k_wear_si_from_seed(c.k_seed);
    o.k_pitting = 1e-93;  // pitting on, so its per-point Hertz terms are part of the cost
    o.operating_point = {c.speed, c.torque};
    o.force_model = c.model;
    o.initial_step_cycles = 10;
    o.max_step_cycles = 10;  // fixed small steps: every step is accepted, one force evaluation each
    wear::BlueLoop loop(twin::GearboxParameters{}, o);
    constexpr int kSteps = 20;
    const int evaluations_before = loop.force_evaluations();
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < kSteps; ++i) loop.step(1e12);
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("blue-loop step, %-14s %4.0f Hz %4.0f N m: %8.2f ms per step (%d steps, %d force evaluations, %d rejected)\n",
                c.name, c.speed, c.torque, 1e3 * wall / kSteps, kSteps, loop.force_evaluations() - evaluations_before,
                loop.rejections());
  }
  return 0;
}
