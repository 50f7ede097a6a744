// Loads tests/protocol/golden_vectors.txt (written by gen_vectors.py) for the protocol tests
// and the firmware-in-the-loop tests, and turns a vector's fields into protocol structs.
#pragma once

#include "protocol.h"

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace auger::test {

struct GoldenVector {
    std::string name;
    std::string kind;  // setpoint, config, config_report, request, telemetry, identity, fault
    std::map<std::string, std::string> fields;
    std::vector<uint8_t> bytes;  // the whole frame
    int line = 0;
};

// Throws std::runtime_error naming file and line on any malformed line.
std::vector<GoldenVector> load_golden_vectors(const std::string& path);

// Path of the checked-in vectors (compile definition AUGER_GOLDEN_VECTORS).
std::string golden_vectors_path();

// Field conversions; throw if a field is missing or out of range.
proto_setpoint_t to_setpoint(const GoldenVector& v);
proto_config_t to_config(const GoldenVector& v);
proto_request_t to_request(const GoldenVector& v);
proto_telemetry_t to_telemetry(const GoldenVector& v);
proto_identity_t to_identity(const GoldenVector& v);
proto_fault_t to_fault(const GoldenVector& v);

// Encodes the vector's fields with the C packing functions.
std::vector<uint8_t> encode_fields(const GoldenVector& v);

}  // namespace auger::test
