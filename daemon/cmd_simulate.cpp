// `gearwatch simulate --out FILE ...`: one synthetic rig capture in protocol v1.
#include <iostream>

#include "capture_writer.hpp"
#include "cli_common.hpp"
#include "decoder_setup.hpp"
#include "gearwatch/config/twin_config.hpp"
#include "gearwatch/twin/simulation.hpp"

namespace gearwatch::cli {

void register_simulate(CLI::App& app) {
  struct Options {
    std::string out, config;
    daemon::CaptureSettings cs;
    bool classic = false, fd = false;
    std::string physics = "synthetic";
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("simulate", "Write a synthetic rig capture (protocol v1, candump -L log)");
  cmd->add_option("--out", opt->out, "Output capture file")->required();
  cmd->add_option("--duration", opt->cs.duration_s, "Seconds of signal")->check(CLI::Range(0.001, 86400.0))->capture_default_str();
  cmd->add_option("--speed", opt->cs.signal.speed_hz, "Input shaft speed, Hz")->check(CLI::Range(0.1, 1000.0))->capture_default_str();
  cmd->add_option("--torque", opt->cs.signal.torque_nm, "Input torque, N·m")->check(CLI::Range(0.0, 10000.0))->capture_default_str();
  auto* fd = cmd->add_flag("--fd", opt->fd, "CAN FD frames, 30 samples each (default)");
  cmd->add_flag("--classic", opt->classic, "Classic CAN frames, 2 samples each")->excludes(fd);
  cmd->add_option("--channels", opt->cs.signal.channels, "Vibration channels")->check(CLI::Range(1, 8))->capture_default_str();
  cmd->add_option("--sample-rate", opt->cs.signal.sample_rate_hz, "Samples per second")->check(CLI::Range(100.0, 1e6))->capture_default_str();
  cmd->add_option("--speed-fluctuation", opt->cs.signal.speed_fluctuation, "Relative 0.5 Hz speed oscillation")->check(CLI::Range(0.0, 0.5));
  cmd->add_option("--seed", opt->cs.signal.seed, "Noise seed")->capture_default_str();
  cmd->add_option("--start-revs", opt->cs.start_revolutions, "Life counter at the first sample")->capture_default_str();
  cmd->add_option("--stream-id", opt->cs.stream_id, "Stream id in the header")->capture_default_str();
  cmd->add_option("--first-index", opt->cs.first_index, "Sample index of the first sample (u32)")->capture_default_str();
  cmd->add_option("--interface", opt->cs.interface, "Interface name written in the log")->capture_default_str();
  cmd->add_option("--config", opt->config, "Take channel scaling, tacho edges/rev and the twin's [twin] parameters from this config");
  cmd->add_option("--physics", opt->physics,
                  "synthetic: gear-mesh harmonics, modulated resonance and noise of known amplitudes; "
                  "twin: the 21-DOF twin's casing acceleration y6 (one channel, no wear)")
      ->check(CLI::IsMember({"synthetic", "twin"}))
      ->capture_default_str();
  cmd->callback([opt] {
    auto cs = opt->cs;
    cs.fd = !opt->classic;
    if (!opt->config.empty()) {
      const auto cfg = load_config_or_defaults(opt->config);
      cs.scale_m_s2_per_lsb = cfg.rig.channels.front().scale_m_s2_per_lsb;
      cs.edges_per_rev = cfg.rig.tachos.front().edges_per_rev;
      cs.signal.pinion_teeth = cfg.rig.gears.pinion_teeth;
      cs.ids = daemon::protocol_ids(cfg);
    }
    if (!cs.fd && cs.signal.sample_rate_hz * cs.signal.channels > 20000)
      std::cerr << "gearwatch: note: classic CAN carries ~10 kHz per channel at most; this capture is for bench replay only\n";
    daemon::CaptureSummary s;
    try {
      if (opt->physics == "twin") {
        if (cs.edges_per_rev != 1) throw CommandError("--physics twin gives one tacho edge per revolution: set edges_per_rev = 1");
        const auto params = opt->config.empty() ? twin::GearboxParameters{} : config::load_twin_parameters(opt->config);
        auto y6 = twin::simulate_casing_signal(params, twin::ToothProfileDeviation{},
                                               twin::OperatingPoint{cs.signal.speed_hz, cs.signal.torque_nm}, cs.duration_s,
                                               cs.signal.sample_rate_hz);
        cs.signal.channels = 1;
        auto signal = daemon::sampled_capture_signal(y6.sample_rate_hz, std::move(y6.acceleration), std::move(y6.tacho_edges));
        s = daemon::write_capture(cs, *signal, opt->out);
      } else {
        s = daemon::write_synthetic_capture(cs, opt->out);
      }
    } catch (const CommandError&) {
      throw;
    } catch (const std::exception& e) {
      throw CommandError(e.what());
    }
    std::cout << "wrote " << opt->out << ": " << s.frames << " frames, " << s.samples_per_channel << " samples x "
              << cs.signal.channels << " channels, " << s.tacho_edges << " tacho edges, " << s.clipped_samples
              << " clipped samples\n";
  });
}

}  // namespace gearwatch::cli
