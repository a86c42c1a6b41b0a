#pragma once
// One entry point per input parser (docs/reliability-inputs.md), in the shape libFuzzer calls:
// int f(const uint8_t* data, size_t size), returning 0. Each feeds the bytes to the parser as
// the program would (a file's text, a byte stream, a log line), lets the expected SetupError
// go, and checks what was accepted: a decoded value outside its range, or any other exception,
// ends the process (a finding). Two drivers call them: corpus_test.cpp (GoogleTest, every seed
// of tests/fuzz/<name>/corpus, any compiler) and libfuzzer_main.cpp (the `fuzz` preset).

#include <cstddef>
#include <cstdint>

namespace nvs::fuzz {

int dbc(const std::uint8_t* data, std::size_t size);           // DBC text
int candump(const std::uint8_t* data, std::size_t size);       // candump log lines → track
int nmea(const std::uint8_t* data, std::size_t size);          // serial bytes, NMEA 0183
int mavlink(const std::uint8_t* data, std::size_t size);       // serial bytes, MAVLink v1/v2
int scenario(const std::uint8_t* data, std::size_t size);      // scenario TOML
int camera(const std::uint8_t* data, std::size_t size);        // camera preset TOML
int csv(const std::uint8_t* data, std::size_t size);           // CSV tables (spectra)
int obj(const std::uint8_t* data, std::size_t size);           // OBJ meshes
int image(const std::uint8_t* data, std::size_t size);         // PGM, PFM, EXR by magic
int framePattern(const std::uint8_t* data, std::size_t size);  // "{frame:06d}" names
int dataset(const std::uint8_t* data, std::size_t size);       // dataset.toml + frames
int outputPaths(const std::uint8_t* data, std::size_t size);   // output path checks

struct Target {
    const char* name;  // also the folder tests/fuzz/<name>
    int (*run)(const std::uint8_t*, std::size_t);
};
inline constexpr Target kTargets[] = {
    {"dbc", dbc},           {"candump", candump},
    {"nmea", nmea},         {"mavlink", mavlink},
    {"scenario", scenario}, {"camera", camera},
    {"csv", csv},           {"obj", obj},
    {"image", image},       {"frame_pattern", framePattern},
    {"dataset", dataset},   {"output_paths", outputPaths},
};

}  // namespace nvs::fuzz
