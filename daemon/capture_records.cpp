#include "capture_records.hpp"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include "decoder_setup.hpp"
#include "gearwatch/acquisition/candump_log.hpp"
#include "gearwatch/acquisition/candump_source.hpp"
#include "gearwatch/acquisition/protocol_decoder.hpp"
#include "gearwatch/acquisition/record_assembler.hpp"

namespace gearwatch::daemon {

std::vector<Record> read_capture_records(const std::string& capture, const config::GearwatchConfig& cfg) {
  acquisition::require_capture_file(capture);
  std::ifstream in(capture, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read capture " + capture + ": " + std::strerror(errno));
  std::vector<Record> records;
  acquisition::RecordAssembler assembler(cfg.rig, {[&](Record&& r, bool analysable) {
                                                     if (analysable) records.push_back(std::move(r));
                                                   },
                                                   {}, {}, {}, {}, {}});
  acquisition::ProtocolDecoder decoder = make_decoder(cfg, [&](const acquisition::AcquisitionEvent& e) { assembler.consume(e); });
  std::string line, reason;
  while (std::getline(in, line))
    if (auto parsed = acquisition::parse_candump_line(line, reason)) decoder.decode(parsed->frame);
  if (in.bad()) throw std::runtime_error("cannot read capture " + capture + ": " + std::strerror(errno));
  assembler.finish();
  if (records.empty())
    throw std::runtime_error(capture + ": no complete record could be cut from it (records.min_length_s = " +
                             std::to_string(cfg.rig.schedule.min_length_s) + " s, records.length_s = " +
                             std::to_string(cfg.rig.schedule.length_s) + " s)");
  return records;
}

}  // namespace gearwatch::daemon
