// `gearwatch twin wear`: the blue loop open-loop from an unworn pair (docs/wear.md).
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "gearwatch/twin/errors.hpp"
#include "gearwatch/types/token.hpp"
#include "gearwatch/wear/wear_loop.hpp"

namespace gearwatch::cli {
namespace {

struct WearOptions {
  double k_wear = 0, torque = 0, speed = 0, cycles = 0, k_pitting = 0;
  std::string format = "table";
  std::string force_model = wear::to_string(wear::ForceModel::quasi_static);  ///< a to_string(ForceModel) token (checked by CLI11)
};

// Limits that catch typing errors, far outside the rig (4 kW motor, ≤ 60 Hz) yet never binding on it.
void check(const WearOptions& o) {
  auto bad = [](const std::string& what) { throw CommandError("twin wear: " + what); };
  if (!std::isfinite(o.k_wear) || o.k_wear < 0 || o.k_wear > 1e-3)
    bad("--k-wear must be finite and in [0, 1e-3] (the thesis's unit, e.g. 1.65e-6)");
  if (!std::isfinite(o.torque) || o.torque <= 0 || o.torque > 1000) bad("--torque must be finite and in (0, 1000] N m");
  if (!std::isfinite(o.speed) || o.speed <= 0 || o.speed > 200) bad("--speed must be finite and in (0, 200] Hz");
  if (!std::isfinite(o.cycles) || o.cycles <= 0 || o.cycles > 1e10) bad("--cycles must be finite and in (0, 1e10]");
  if (!std::isfinite(o.k_pitting) || o.k_pitting < 0) bad("--k-pitting must be finite and non-negative");
}

nlohmann::json to_um(const std::vector<double>& metres) {
  nlohmann::json a = nlohmann::json::array();
  for (double v : metres) a.push_back(v * 1e6);
  return a;
}

void run_wear(const WearOptions& o) {
  check(o);
  wear::WearLoopOptions options;
  options.k_wear_si = wear::k_wear_si_from_seed(o.k_wear);
  options.k_pitting = o.k_pitting;
  options.operating_point = {o.speed, o.torque};
  options.force_model = *from_token(wear::kAllForceModels, o.force_model);  // CLI11 checked the token
  bool completed = false;
  std::unique_ptr<wear::BlueLoop> loop;
  try {
    loop = std::make_unique<wear::BlueLoop>(twin::GearboxParameters{}, options);
    completed = loop->run_until(o.cycles);
  } catch (const std::exception& e) {
    throw CommandError(std::string("twin wear: ") + e.what());
  }
  const wear::WearState& state = loop->state();
  if (!completed) {
    char msg[200];
    std::snprintf(msg, sizeof msg, "twin wear: a flank reaches the %.1f mm depth limit after %.4g of %.4g cycles (K or load too large)",
                  options.depth_limit_m * 1e3, state.cycles, o.cycles);
    throw CommandError(msg);
  }
  const wear::WearSummary s = wear::summarise(state);
  const std::vector<double> combined = wear::combined_profile(state);
  const std::size_t n = state.pinion_depth_m.size();
  if (o.format == "json") {
    nlohmann::json fractions = nlohmann::json::array();
    for (std::size_t j = 0; j < n; ++j) fractions.push_back(static_cast<double>(j) / static_cast<double>(n - 1));
    const nlohmann::json out{{"k_wear", o.k_wear},
                             {"k_wear_si", options.k_wear_si},
                             {"k_pitting", o.k_pitting},
                             {"torque_nm", o.torque},
                             {"speed_hz", o.speed},
                             {"cycles", s.cycles},
                             {"force_model", o.force_model},
                             {"pinion_mean_depth_um", s.pinion_mean_depth_m * 1e6},
                             {"gear_mean_depth_um", s.gear_mean_depth_m * 1e6},
                             {"combined_mean_depth_um", s.combined_mean_depth_m * 1e6},
                             {"pinion_share", s.pinion_share},
                             {"mean_pitting_density", s.mean_pitting_density},
                             {"max_pitting_density", s.max_pitting_density},
                             {"max_pitting_profile_fraction", s.max_pitting_fraction},
                             {"profile_fraction", fractions},
                             {"pinion_depth_um", to_um(state.pinion_depth_m)},
                             {"gear_depth_um", to_um(state.gear_depth_m)},
                             {"combined_depth_um", to_um(combined)},
                             {"pinion_pitting_density", state.pinion_pitting},
                             {"steps", loop->steps()},
                             {"rejected_steps", loop->rejections()}};
    std::printf("%s\n", out.dump(1).c_str());
    return;
  }
  std::printf("Open-loop wear from an unworn pair: K_wear %.4g (thesis's unit) = %.4g m2/N, %.4g N m, %.4g Hz, %.6g cycles (%s force)\n",
              o.k_wear, options.k_wear_si, o.torque, o.speed, s.cycles, o.force_model.c_str());
  std::printf("mean wear depth: pinion %.4f um, gear %.4f um, combined %.4f um (pinion share %.1f %%)\n",
              s.pinion_mean_depth_m * 1e6, s.gear_mean_depth_m * 1e6, s.combined_mean_depth_m * 1e6, 100 * s.pinion_share);
  std::printf("mean pitting density (pinion): %.4f %% (max %.4f %% at profile fraction %.2f; K_pitting %.4g)\n",
              100 * s.mean_pitting_density, 100 * s.max_pitting_density, s.max_pitting_fraction, o.k_pitting);
  std::printf("\nroot -> tip (profile fraction; pinion and gear each from their own root; combined along the pinion)\n");
  std::printf("%8s %12s %12s %14s %10s\n", "fraction", "pinion (um)", "gear (um)", "combined (um)", "pitting %");
  for (std::size_t j = 0; j < n; j += (n - 1) / 10 > 0 ? (n - 1) / 10 : 1)
    std::printf("%8.2f %12.4f %12.4f %14.4f %10.4f\n", static_cast<double>(j) / static_cast<double>(n - 1),
                state.pinion_depth_m[j] * 1e6, state.gear_depth_m[j] * 1e6, combined[j] * 1e6,
                100 * state.pinion_pitting[j]);
  std::printf("(%d steps, %d rejected)\n", loop->steps(), loop->rejections());
}

}  // namespace

void register_twin_wear(CLI::App* twin) {
  auto o = std::make_shared<WearOptions>();
  auto* cmd = twin->add_subcommand("wear", "Open-loop wear and pitting from an unworn pair (the blue loop, docs/wear.md)");
  cmd->add_option("--k-wear", o->k_wear, "Archard K_wear in the thesis's unit (e.g. 1.65e-6 dry, 3.55e-10 lubricated)")->required();
  cmd->add_option("--torque", o->torque, "Input torque (N m)")->required();
  cmd->add_option("--speed", o->speed, "Input shaft speed (Hz)")->required();
  cmd->add_option("--cycles", o->cycles, "Pinion revolutions")->required();
  cmd->add_option("--k-pitting", o->k_pitting, "Lundberg-Palmgren K_pitting (SI, docs/wear.md); 0 = no pitting")->capture_default_str();
  cmd->add_option("--format", o->format, "table | json")->check(CLI::IsMember({"table", "json"}));
  std::vector<std::string> force_models;
  for (wear::ForceModel m : wear::kAllForceModels) force_models.emplace_back(wear::to_string(m));
  cmd->add_option("--force-model", o->force_model,
                  "quasi-static (load sharing, ms per step) | dynamic (21-DOF twin per step, much slower)")
      ->check(CLI::IsMember(force_models))
      ->capture_default_str();
  cmd->callback([o] { run_wear(*o); });
}

}  // namespace gearwatch::cli
