// RS-170 field timing end to end (`nvstim run`, y4m and metadata): a field-scan camera runs
// interlaced by default; its fields are 1/59.94 s apart, each exposed at its own time; a bar
// moving at v px/s is displaced by v/59.94 between the two fields of a frame; both fields of
// every frame are fresh; frame 0 is complete; the y4m header says top field first, and
// ffprobe (when present) reads it so.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "test_paths.h"

namespace nvs {
namespace {

namespace fs = std::filesystem;

constexpr int kW = 256;
constexpr int kH = 64;
constexpr double kFieldRate_Hz = 60000.0 / 1001.0;  // RS-170
constexpr double kSpeed_px_s = 599.4;               // 10 px per field

int sh(const std::string& cmd, std::string* out = nullptr) {
    FILE* p = popen(cmd.c_str(), "r");
    if (p == nullptr) return -1;
    std::array<char, 4096> buf{};
    std::size_t n = 0;
    while ((n = fread(buf.data(), 1, buf.size(), p)) > 0)
        if (out != nullptr) out->append(buf.data(), n);
    const int st = pclose(p);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

std::string slurp(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

class FieldTiming : public ::testing::Test {
  protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("nvs_field_timing_" + std::to_string(::getpid()));
        fs::create_directories(dir_);
        // The PULNiX preset (field scan, 59.94 Hz) with its noise, blur, afterglow and AGC off:
        // each field's rows are a deterministic image of the scene at that field's time.
        std::ofstream(dir_ / "scenario.toml")
            << "[scenario]\nname = \"bar\"\nwidth = " << kW << "\nheight = " << kH
            << "\n[camera]\npreset = \"pulnix-ag5745ef3\"\n"
               "set = [\"mtf.enabled=false\", \"phosphor.enabled=false\", "
               "\"photocathode.shot_noise=false\", \"mcp.noise=false\", \"ccd.read_noise_e=0\", "
               "\"video.noise_dc=0\"]\n"
               "[platform]\nagc = false\ngain_V = 6.0\n"
               "[[source]]\nkind = \"test_pattern\"\nradiance_max_W_m2_sr = "
               "2e-3\ntarget_speed_px_s = "
            << kSpeed_px_s << "\n";
    }
    void TearDown() override { fs::remove_all(dir_); }

    // Runs `frames` frames to y4m and metadata; returns the frames (8-bit luma).
    std::vector<std::string> run(int frames, std::string* header) {
        const std::string cmd = std::string(NVSTIM_EXE) + " run " +
                                (dir_ / "scenario.toml").string() + " --clock sim --frames " +
                                std::to_string(frames) +
                                " --output y4m:" + (dir_ / "out.y4m").string() +
                                " --output meta:" + (dir_ / "out.jsonl").string() + " 2>/dev/null";
        EXPECT_EQ(sh(cmd), 0) << cmd;
        const std::string y4m = slurp(dir_ / "out.y4m");
        const std::size_t eol = y4m.find('\n');
        *header = y4m.substr(0, eol);
        std::vector<std::string> out;
        const std::size_t frameBytes = 6 + static_cast<std::size_t>(kW) * kH;
        for (std::size_t at = eol + 1; at + frameBytes <= y4m.size(); at += frameBytes) {
            EXPECT_EQ(y4m.compare(at, 6, "FRAME\n"), 0);
            out.push_back(y4m.substr(at + 6, frameBytes - 6));
        }
        return out;
    }

    // Left edge of the moving target on row y: the first pixel above half the row's maximum.
    static int edge(const std::string& frame, int y) {
        const auto* row = reinterpret_cast<const unsigned char*>(frame.data()) + y * kW;
        int maxV = 0;
        for (int x = 0; x < kW; ++x)
            maxV = std::max(maxV, static_cast<int>(row[x]));
        for (int x = 0; x < kW; ++x)
            if (2 * row[x] > maxV) return x;
        return -1;
    }

    static std::string fieldRows(const std::string& frame, int parity) {
        std::string rows;
        for (int y = parity; y < kH; y += 2)
            rows.append(frame, static_cast<std::size_t>(y) * kW, kW);
        return rows;
    }

    fs::path dir_;
};

TEST_F(FieldTiming, BarMovesBetweenTheTwoFreshFieldsOfEveryFrame) {
    std::string header;
    const std::vector<std::string> frames = run(4, &header);
    ASSERT_EQ(frames.size(), 4u);
    // 29.97 frames/s of two fields, top field first.
    EXPECT_NE(header.find(" F30000:1001 "), std::string::npos) << header;
    EXPECT_NE(header.find(" It "), std::string::npos) << header;
    const double fieldShift_px = kSpeed_px_s / kFieldRate_Hz;  // 10 px
    for (std::size_t k = 0; k < frames.size(); ++k) {
        // The target fills the bottom rows: row kH−2 is field 0's (even), kH−1 field 1's.
        const int x0 = edge(frames[k], kH - 2);
        const int x1 = edge(frames[k], kH - 1);
        ASSERT_GE(x0, 0) << "frame " << k << ": field 0 is empty";
        ASSERT_GE(x1, 0) << "frame " << k << ": field 1 is empty";
        if (k == 0) continue;  // field 0 of frame 0 is before t = 0: the target wraps
        EXPECT_NEAR(x1 - x0, fieldShift_px, 1.0) << "frame " << k;
        // Field 0 of frame k follows field 1 of frame k − 1 by one field period.
        EXPECT_NEAR(x0 - edge(frames[k - 1], kH - 1), fieldShift_px, 1.0) << "frame " << k;
        // Both fields are new: neither repeats the previous frame's rows.
        EXPECT_NE(fieldRows(frames[k], 0), fieldRows(frames[k - 1], 0)) << "frame " << k;
        EXPECT_NE(fieldRows(frames[k], 1), fieldRows(frames[k - 1], 1)) << "frame " << k;
    }
    // Frame 0 is complete: its odd rows carry the scene (the grey bars above the target), not 0.
    int oddLit = 0;
    for (int y = 1; y < kH / 2; y += 2)
        oddLit +=
            static_cast<unsigned char>(frames[0][static_cast<std::size_t>(y) * kW + kW - 1]) > 0;
    EXPECT_EQ(oddLit, kH / 4);
}

TEST_F(FieldTiming, MetadataListsBothFieldsOneFieldPeriodApart) {
    std::string header;
    (void)run(3, &header);
    std::ifstream meta(dir_ / "out.jsonl");
    std::string line;
    int n = 0;
    while (std::getline(meta, line)) {
        // "fields":[{"t_sample_s":A,...},{"t_sample_s":B,...}]
        const std::size_t f = line.find("\"fields\":[");
        ASSERT_NE(f, std::string::npos) << line;
        const std::size_t a = line.find("\"t_sample_s\":", f);
        const std::size_t b = line.find("\"t_sample_s\":", a + 1);
        ASSERT_NE(b, std::string::npos);
        const double t0 = std::stod(line.substr(a + 13));
        const double t1 = std::stod(line.substr(b + 13));
        EXPECT_NEAR(t1 - t0, 1.0 / kFieldRate_Hz, 1e-8);
        EXPECT_NEAR(t1, n * 2.0 / kFieldRate_Hz, 1e-8);  // the frame completes at t_k
        // Each field is exposed for at most one field period.
        const std::size_t e = line.find("\"exposure_s\":");
        EXPECT_LE(std::stod(line.substr(e + 13)), 1.0 / kFieldRate_Hz + 1e-9);
        ++n;
    }
    EXPECT_EQ(n, 3);
}

TEST_F(FieldTiming, FfprobeReadsTheY4mAsInterlacedTopFieldFirst) {
    if (sh("command -v ffprobe >/dev/null 2>&1") != 0) {
        GTEST_SKIP() << "ffprobe not installed (Debian package ffmpeg)";
    }
    std::string header;
    (void)run(2, &header);
    std::string out;
    ASSERT_EQ(sh("ffprobe -v error -show_entries stream=field_order -of csv=p=0 " +
                     (dir_ / "out.y4m").string(),
                 &out),
              0);
    EXPECT_EQ(out.substr(0, 2), "tt") << out;
}

// The CCIR preset: 25 frames/s of two 50 Hz fields, by default, from the preset alone.
TEST_F(FieldTiming, CcirPresetRunsAt25FramesOf50HzFields) {
    std::string text = slurp(dir_ / "scenario.toml");
    text.replace(text.find("pulnix-ag5745ef3"), 16, "pulnix-ag5745ef3-ccir");
    std::ofstream(dir_ / "scenario.toml") << text;
    std::string header;
    (void)run(2, &header);
    EXPECT_NE(header.find(" F25:1 "), std::string::npos) << header;
    EXPECT_NE(header.find(" It "), std::string::npos) << header;
    std::ifstream meta(dir_ / "out.jsonl");
    std::string line;
    ASSERT_TRUE(std::getline(meta, line));
    const std::size_t a = line.find("\"t_sample_s\":", line.find("\"fields\":["));
    const std::size_t b = line.find("\"t_sample_s\":", a + 1);
    EXPECT_NEAR(std::stod(line.substr(b + 13)) - std::stod(line.substr(a + 13)), 1.0 / 50.0, 1e-9);
}

TEST_F(FieldTiming, ProgressiveFieldCameraAtAnotherRateIsRefused) {
    std::ofstream(dir_ / "scenario.toml", std::ios::app) << "";
    std::string text = slurp(dir_ / "scenario.toml");
    text.replace(text.find("name = \"bar\""), 12,
                 "name = \"bar\"\nscan = \"progressive\"\nframe_rate_hz = 29.97");
    std::ofstream(dir_ / "scenario.toml") << text;
    std::string out;
    const int rc = sh(std::string(NVSTIM_EXE) + " run " + (dir_ / "scenario.toml").string() +
                          " --clock sim --frames 1 --output y4m:/dev/null 2>&1",
                      &out);
    EXPECT_EQ(rc, 2) << out;
    EXPECT_NE(out.find("frame_rate_hz"), std::string::npos) << out;
    EXPECT_NE(out.find("field rate"), std::string::npos) << out;
}

// field_rows = "own" (the default): each field renders only the rows its camera reads out, the
// other rows holding the previous field's radiance, which reach the field's output only through
// the tube's blur, halo and afterglow. On the airborne pass (the camera moving ~7 px per field)
// the output must differ from rendering every row by far less than the camera's own noise: the
// RMS difference is measured against the RMS difference of two noise seeds (2σ²).
TEST(FieldRows, OwnRowsDifferFromAllRowsByAFractionOfTheNoise) {
    const fs::path dir =
        fs::temp_directory_path() / ("nvs_field_rows_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    const fs::path air = test::sourceDir() / "scenarios" / "airborne-pass";
    std::string toml = slurp(air / "scenario.toml");
    const auto replace = [&](const std::string& from, const std::string& to) {
        const std::size_t at = toml.find(from);
        ASSERT_NE(at, std::string::npos) << from;
        toml.replace(at, from.size(), to);
    };
    replace("\"../rit/", "\"" + (air.parent_path() / "rit").string() + "/");
    replace("replay:flight.candump", "replay:" + (air / "flight.candump").string());
    constexpr int kFrames = 8;
    const auto frames = [&](const std::string& name, const std::string& extra) {
        const fs::path sc = dir / (name + ".toml");
        std::ofstream(sc) << toml << extra;
        const fs::path out = dir / (name + ".y4m");
        const std::string cmd = std::string(NVSTIM_EXE) + " run " + sc.string() +
                                " --clock sim --frames " + std::to_string(kFrames) +
                                " --output y4m:" + out.string() + " 2>/dev/null";
        EXPECT_EQ(sh(cmd), 0) << cmd;
        return slurp(out);
    };
    const std::string own = frames("own", "\n[runtime]\nfield_rows = \"own\"\n");
    const std::string all = frames("all", "\n[runtime]\nfield_rows = \"all\"\n");
    // The same frames with another noise draw: the scenario's seed 9 becomes 19.
    const std::size_t seedAt = toml.find("seed = ");
    ASSERT_NE(seedAt, std::string::npos);
    toml.insert(seedAt + 7, "1");
    const std::string reseeded = frames("seed", "\n[runtime]\nfield_rows = \"all\"\n");
    ASSERT_EQ(own.size(), all.size());
    ASSERT_EQ(own.size(), reseeded.size());
    const auto meanSquare = [](const std::string& a, const std::string& b) {
        double s = 0.0;
        std::size_t n = 0;
        for (std::size_t i = 0; i < a.size(); ++i) {
            const double d = static_cast<unsigned char>(a[i]) - static_cast<unsigned char>(b[i]);
            s += d * d;
            ++n;
        }
        return s / static_cast<double>(n);
    };
    const double rowsMs = meanSquare(own, all);
    const double noiseMs = meanSquare(all, reseeded);  // 2σ² of the camera noise
    std::printf("field rows: mean-square difference %.3f DC², two noise seeds %.1f DC²\n", rowsMs,
                noiseMs);
    EXPECT_GT(noiseMs, 10.0);           // the comparison has noise to compare with
    EXPECT_GT(rowsMs, 0.0);             // and the two renders differ (a moving camera)
    EXPECT_LT(rowsMs, 0.01 * noiseMs);  // below 1 % of the noise variance
    fs::remove_all(dir);
}

}  // namespace
}  // namespace nvs
