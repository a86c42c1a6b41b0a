#include "rt/replay/replay.h"

#include <fcntl.h>
#include <gnu/libc-version.h>
#include <openssl/evp.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <regex>
#include <sstream>
#include <vector>

#include "rt/compose/environment.h"
#include "sim/core/config.h"
#include "sim/core/cpu_isa.h"
#include "sim/core/error.h"
#include "sim/core/image.h"
#include "sim/core/output_file.h"
#include "sim/io/image_file.h"
#include "sim/io/pnm.h"

extern char** environ;

namespace nvs::rt {
namespace fs = std::filesystem;
namespace {

constexpr double kZLimit = 5.0;
constexpr double kMeanFloor_counts = 0.5;
constexpr double kVarianceTolerance = 0.25;
constexpr int kMaxWindows = 3;
// Whole-window limits: |z| of the mean shift, the shift it must also exceed, and the relative
// change of the mean noise variance (its sampling error over ~6000 blocks × 30 frames is well
// under 1 %).
constexpr double kGlobalZLimit = 6.0;
constexpr double kGlobalMeanFloor_counts = 0.05;
constexpr double kGlobalVarianceTolerance = 0.03;

std::string sha256File(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    if (!in) throw SetupError(FileLoc{p.string()}, "cannot read replay output");
    EVP_MD_CTX* ctx = EVP_MD_CTX_new();
    EVP_DigestInit_ex(ctx, EVP_sha256(), nullptr);
    std::vector<char> buf(1 << 16);
    while (in) {
        in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
        EVP_DigestUpdate(ctx, buf.data(), static_cast<std::size_t>(in.gcount()));
    }
    unsigned char md[EVP_MAX_MD_SIZE];
    unsigned int n = 0;
    EVP_DigestFinal_ex(ctx, md, &n);
    EVP_MD_CTX_free(ctx);
    std::string hex;
    char b[3];
    for (unsigned int i = 0; i < n; ++i) {
        std::snprintf(b, sizeof b, "%02x", md[i]);
        hex += b;
    }
    return hex;
}

std::vector<fs::path> framesIn(const fs::path& dir) {
    std::vector<fs::path> f;
    for (const auto& e : fs::directory_iterator(dir)) {
        if (e.path().extension() == ".pgm") f.push_back(e.path());
    }
    std::sort(f.begin(), f.end());
    return f;
}

// Block statistics of one window of frames.
struct WindowStats {
    int first = 0, count = 0;
    int blocksX = 0, blocksY = 0;
    ImageF mean, meanVar, pixVar;  // per block
    double level = 0.0, noise = 0.0;
};

std::vector<std::pair<int, int>> windowsFor(int frames) {
    std::vector<std::pair<int, int>> w;
    if (frames <= 0) return w;
    const int n = frames < 20 ? 1 : std::min(kMaxWindows, frames / 20);
    const int size = frames / n;
    for (int i = 0; i < n; ++i)
        w.emplace_back(i * size, size);
    return w;
}

WindowStats computeWindow(const std::vector<fs::path>& frames, int first, int count) {
    WindowStats s;
    s.first = first;
    s.count = count;
    const ImageU16 f0 = io::readPgm(frames[first]);
    const int w = f0.width(), h = f0.height();
    s.blocksX = w / kReplayBlock_px;
    s.blocksY = h / kReplayBlock_px;
    const std::size_t nb = static_cast<std::size_t>(s.blocksX) * s.blocksY;
    std::vector<double> bSum(nb, 0.0), bSq(nb, 0.0);
    std::vector<double> pSum(static_cast<std::size_t>(w) * h, 0.0), pSq(pSum.size(), 0.0);
    for (int k = first; k < first + count; ++k) {
        const ImageU16 img = io::readPgm(frames[k]);
        if (img.width() != w || img.height() != h) {
            throw SetupError(FileLoc{frames[k].string()}, "frame size changed during the replay");
        }
        for (int by = 0; by < s.blocksY; ++by) {
            for (int bx = 0; bx < s.blocksX; ++bx) {
                double m = 0.0;
                for (int y = by * kReplayBlock_px; y < (by + 1) * kReplayBlock_px; ++y) {
                    const std::uint16_t* r = img.row(y);
                    for (int x = bx * kReplayBlock_px; x < (bx + 1) * kReplayBlock_px; ++x) {
                        const double v = r[x];
                        m += v;
                        const std::size_t p = static_cast<std::size_t>(y) * w + x;
                        pSum[p] += v;
                        pSq[p] += v * v;
                    }
                }
                m /= kReplayBlock_px * kReplayBlock_px;
                const std::size_t b = static_cast<std::size_t>(by) * s.blocksX + bx;
                bSum[b] += m;
                bSq[b] += m * m;
            }
        }
    }
    s.mean = ImageF(s.blocksX, s.blocksY);
    s.meanVar = ImageF(s.blocksX, s.blocksY);
    s.pixVar = ImageF(s.blocksX, s.blocksY);
    const double n = count;
    for (int by = 0; by < s.blocksY; ++by) {
        for (int bx = 0; bx < s.blocksX; ++bx) {
            const std::size_t b = static_cast<std::size_t>(by) * s.blocksX + bx;
            const double mu = bSum[b] / n;
            const double mv = count > 1 ? std::max(0.0, (bSq[b] - n * mu * mu) / (n - 1)) : 0.0;
            double pv = 0.0;
            for (int y = by * kReplayBlock_px; y < (by + 1) * kReplayBlock_px; ++y) {
                for (int x = bx * kReplayBlock_px; x < (bx + 1) * kReplayBlock_px; ++x) {
                    const std::size_t p = static_cast<std::size_t>(y) * w + x;
                    const double pm = pSum[p] / n;
                    pv += count > 1 ? std::max(0.0, (pSq[p] - n * pm * pm) / (n - 1)) : 0.0;
                }
            }
            pv /= kReplayBlock_px * kReplayBlock_px;
            s.mean(bx, by) = static_cast<float>(mu);
            s.meanVar(bx, by) = static_cast<float>(mv);
            s.pixVar(bx, by) = static_cast<float>(pv);
            s.level += mu;
            s.noise += pv;
        }
    }
    s.level /= static_cast<double>(nb);
    s.noise /= static_cast<double>(nb);
    return s;
}

// Runs argv, stdout/stderr to `log`; returns the exit status.
int runProcess(const std::vector<std::string>& args, const fs::path& log) {
    std::vector<char*> argv;
    for (const auto& a : args)
        argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&fa, 1, 2);
    // A parent that ignores SIGCHLD makes the kernel reap children itself: waitpid() then waits
    // for the child and fails with ECHILD, and its status is lost (wait(2), "NOTES"). The
    // default disposition is restored around the child's life, and waitpid() is retried only
    // on EINTR: any other failure is an error, never a spin.
    struct sigaction dfl {
    }, old{};
    dfl.sa_handler = SIG_DFL;
    sigemptyset(&dfl.sa_mask);
    sigaction(SIGCHLD, &dfl, &old);
    posix_spawnattr_t attr;
    posix_spawnattr_init(&attr);
    sigset_t defaults;
    sigemptyset(&defaults);
    sigaddset(&defaults, SIGCHLD);
    sigaddset(&defaults, SIGPIPE);
    posix_spawnattr_setsigdefault(&attr, &defaults);
    posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGDEF);
    pid_t pid = 0;
    const int rc = posix_spawn(&pid, argv[0], &fa, &attr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    posix_spawnattr_destroy(&attr);
    if (rc != 0) {
        sigaction(SIGCHLD, &old, nullptr);
        throw SetupError(std::string("cannot start ") + args[0] + ": " + std::strerror(rc));
    }
    int status = 0;
    pid_t got = 0;
    do {
        got = waitpid(pid, &status, 0);
    } while (got < 0 && errno == EINTR);
    const int waitErr = got < 0 ? errno : 0;
    sigaction(SIGCHLD, &old, nullptr);
    if (got < 0) {
        throw SetupError(std::string("waiting for ") + args[0] + ": " + std::strerror(waitErr));
    }
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

// A private working folder under $TMPDIR (mkdtemp: mode 0700, a name no other run can have),
// removed when the object goes.
class TempDir {
  public:
    TempDir() : path_(makeReplayTempDir()) {}
    ~TempDir() {
        if (keep_) return;
        std::error_code ec;
        fs::remove_all(path_, ec);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
    const fs::path& path() const { return path_; }
    void keep() { keep_ = true; }

  private:
    fs::path path_;
    bool keep_ = false;
};

bool isSha256Hex(const std::string& s) {
    return s.size() == 64 && std::all_of(s.begin(), s.end(), [](char c) {
               return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f');
           });
}

// A reference image read back for the comparison: its size must be the window's block grid and
// every value finite (a NaN would make every comparison with it false, i.e. pass).
ImageF readReference(const fs::path& p) {
    if (!fs::is_regular_file(p)) throw SetupError(FileLoc{p.string()}, "missing reference image");
    ImageF img = io::readRadiance(p).image;
    for (int y = 0; y < img.height(); ++y)
        for (int x = 0; x < img.width(); ++x)
            if (!std::isfinite(img(x, y))) {
                throw SetupError(FileLoc{p.string()}, "reference value at block " +
                                                          std::to_string(x) + "," +
                                                          std::to_string(y) + " is not finite");
            }
    return img;
}

std::string lastLine(const fs::path& p) {
    std::ifstream in(p);
    std::string line, last;
    while (std::getline(in, line)) {
        if (!line.empty()) last = line;
    }
    return last;
}

std::string tomlString(const std::string& s) {
    std::string o = "\"";
    for (char c : s) {
        if (c == '"' || c == '\\') o += '\\';
        o += c;
    }
    return o + "\"";
}

// An 8-bit picture of |z| (0 → black, ≥ 10 → white), one block per 8×8 pixels.
void writeZMap(const fs::path& p, const ImageF& z) {
    ImageU16 img(z.width() * kReplayBlock_px, z.height() * kReplayBlock_px);
    for (int y = 0; y < img.height(); ++y) {
        for (int x = 0; x < img.width(); ++x) {
            const double a = std::min(
                10.0, std::fabs(static_cast<double>(z(x / kReplayBlock_px, y / kReplayBlock_px))));
            img(x, y) = static_cast<std::uint16_t>(std::lround(a * 25.5));
        }
    }
    io::writePgm(p, img.cview(), 255);
}

}  // namespace

std::string isaFingerprint() {
#if defined(__x86_64__)
    // The level the project's own SIMD code runs at (its dispatch: target_clones and the
    // AVX-512 probes) and, where NVS_EMBREE_ISA pins it lower, Embree's. "avx512f" is the name
    // digests blessed before the level had a name of its own carry.
    const std::string host = hostIsa();
    std::string t = host == "avx512" ? std::string("avx512f") : host;
    const std::string embree = embreeIsa(embreeIsaPin());
    if (embree != host) t += "/embree-" + embree;
    return t;
#else
    return hostIsa();
#endif
}

std::string buildFingerprint() {
    std::string fp = std::string("gcc ") + __VERSION__;
#if defined(__x86_64__)
    fp += " x86_64+" + isaFingerprint();
#elif defined(__aarch64__)
    fp += " aarch64";
#endif
    fp += std::string(" ") + NVS_BUILD_TYPE;
    fp += std::string(" glibc ") + gnu_get_libc_version();
    return fp;
}

std::string fingerprintWithoutIsa(const std::string& fingerprint) {
    // "gcc V x86_64+ISA TYPE glibc G": the word after "x86_64+" is the ISA.
    const std::size_t at = fingerprint.find(" x86_64+");
    if (at == std::string::npos) return fingerprint;
    const std::size_t end = fingerprint.find(' ', at + 1);
    return fingerprint.substr(0, at) + " x86_64" +
           (end == std::string::npos ? std::string() : fingerprint.substr(end));
}

fs::path makeReplayTempDir() {
    std::string tmpl = (fs::temp_directory_path() / "nvstim-replay-XXXXXX").string();
    if (::mkdtemp(tmpl.data()) == nullptr) {
        throw SetupError("cannot create a temporary folder in " +
                         fs::temp_directory_path().string() + ": " + std::strerror(errno));
    }
    return tmpl;
}

fs::path replayScenario(const fs::path& dir, const fs::path& nvstimExe, const fs::path& workDir) {
    const fs::path scenario = dir / "scenario.toml";
    if (!fs::is_directory(dir)) throw SetupError(dir.string() + ": not a scenario folder");
    if (!fs::exists(scenario)) throw SetupError(dir.string() + ": no scenario.toml");
    const fs::path log = workDir / "run.log";
    std::vector<std::string> args = {nvstimExe.string(), "run", scenario.string(), "--clock",
                                     "sim"};
    const std::vector<std::string> channels = rigChannels(dir);
    for (const std::string& ch : channels.empty() ? std::vector<std::string>{""} : channels) {
        // A rig: each channel's frames and metadata in a folder of its own.
        const fs::path out = ch.empty() ? workDir : workDir / ch;
        const std::string route = ch.empty() ? "" : "?channel=" + ch;
        fs::create_directories(out / "frames");
        args.insert(args.end(), {"--output", "pgm:" + (out / "frames").string() + route, "--output",
                                 "meta:" + (out / "meta.jsonl").string() + route});
    }
    const int rc = runProcess(args, log);
    if (rc != 0) {
        throw SetupError(scenario.string() + ": replay run failed (exit " + std::to_string(rc) +
                         "): " + lastLine(log));
    }
    return channels.empty() ? workDir / "frames" : workDir;
}

std::vector<std::string> rigChannels(const fs::path& dir) {
    // The [[channel]] names alone; the run itself checks the whole file.
    const ConfigDocument doc = ConfigDocument::parseFile(dir / "scenario.toml");
    std::vector<std::string> names;
    for (const ConfigTable& c : doc.root().tableArray("channel")) {
        const std::string name = c.require<std::string>("name");
        if (name.empty() || name.find_first_of("/.?&=") != std::string::npos)
            c.fail("name", "not a channel name");  // the run says what is allowed
        names.push_back(name);
    }
    return names;
}

namespace {

// The scenario's expected/ folder, safe to write and clear: a real folder inside the scenario
// folder, never a symbolic link (clearing it would delete wherever the link points).
// DIR/expected, checked: a real folder inside the scenario folder, or one that can be made
// there. Nothing is created (the replay comes first).
fs::path expectedFolder(const fs::path& dir) {
    if (!fs::is_directory(dir)) throw SetupError(dir.string() + ": not a scenario folder");
    if (!fs::exists(dir / "scenario.toml")) throw SetupError(dir.string() + ": no scenario.toml");
    fs::path exp = dir / "expected";
    const fs::file_status st = fs::symlink_status(exp);
    if (fs::is_symlink(st)) {
        throw SetupError(exp.string() +
                         ": is a symbolic link; --bless writes only a real folder "
                         "inside the scenario (replace the link by a folder)");
    }
    if (fs::exists(st) && !fs::is_directory(st)) {
        throw SetupError(exp.string() + ": exists and is not a folder");
    }
    if (::access(fs::exists(st) ? exp.c_str() : dir.c_str(), W_OK | X_OK) != 0)
        throw SetupError(exp.string() + ": cannot write there: " + std::strerror(errno));
    return exp;
}

// What --bless writes (and so may remove): digest.toml, stats.toml, wN_*.pfm.
bool isBlessOutput(const fs::directory_entry& e) {
    if (!e.is_regular_file() || e.is_symlink()) return false;
    static const std::regex names(
        R"((digest|stats)\.toml(\.tmp)?|w[0-9]+_(mean|meanvar|pixvar)\.pfm)");
    return std::regex_match(e.path().filename().string(), names);
}

}  // namespace

namespace {

// The expectations of one stream (a camera, or a rig's channel) from its replay in `work`
// (frames/ and meta.jsonl) into `exp`.
void blessStream(const fs::path& dir, const fs::path& exp, const fs::path& work) {
    const auto files = framesIn(work / "frames");
    if (files.empty()) throw SetupError(dir.string() + ": the replay produced no frames");
    std::error_code ec;
    fs::create_directory(exp, ec);
    if (ec) throw SetupError(exp.string() + ": cannot create: " + ec.message());
    if (fs::canonical(exp).parent_path() != fs::canonical(dir) &&
        fs::canonical(exp).parent_path().parent_path() != fs::canonical(dir)) {
        throw SetupError(exp.string() + ": resolves outside the scenario folder");
    }
    const auto windows = windowsFor(static_cast<int>(files.size()));
    // The new expectations, written beside the old and renamed over them together
    // (sim/core/output_file.h); the old files the new set does not replace are removed after.
    std::vector<fs::path> written = {exp / "digest.toml", exp / "stats.toml"};
    for (std::size_t i = 0; i < windows.size(); ++i)
        for (const char* kind : {"_mean.pfm", "_meanvar.pfm", "_pixvar.pfm"})
            written.push_back(exp / ("w" + std::to_string(i) + kind));
    OutputFiles outputs;
    for (const fs::path& p : written)
        outputs.addFile("--bless", p);

    std::ostringstream d;
    d << "# Written by nvstim replay --bless; compared by --check. Bit-exact for this build "
         "only.\n";
    d << "fingerprint = " << tomlString(buildFingerprint()) << "\n";
    d << "frames = " << files.size() << "\n";
    d << "meta_sha256 = " << tomlString(sha256File(work / "meta.jsonl")) << "\n";
    d << "frame_sha256 = [\n";
    for (const auto& f : files)
        d << "  " << tomlString(sha256File(f)) << ",\n";
    d << "]\n";
    outputs.holdSignals();
    outputs.writeText(exp / "digest.toml", d.str());

    std::ostringstream s;
    s << "# Statistical reference (per " << kReplayBlock_px << "x" << kReplayBlock_px
      << " block): wN_mean.pfm, wN_meanvar.pfm, wN_pixvar.pfm.\n";
    s << "block_px = " << kReplayBlock_px << "\n";
    int i = 0;
    for (const auto& [first, count] : windows) {
        const WindowStats w = computeWindow(files, first, count);
        const std::string stem = "w" + std::to_string(i);
        for (const auto& [kind, img] :
             {std::pair{"_mean.pfm", &w.mean}, std::pair{"_meanvar.pfm", &w.meanVar},
              std::pair{"_pixvar.pfm", &w.pixVar}}) {
            outputs.writeWith(exp / (stem + kind),
                              [&](const fs::path& tmp) { io::writePfm(tmp, img->cview()); });
        }
        char line[256];
        std::snprintf(
            line, sizeof line,
            "\n[[window]]\nfirst = %d\ncount = %d\nlevel_counts = %.4f\nnoise_var_counts2 = %.4f\n",
            first, count, w.level, w.noise);
        s << line;
        ++i;
    }
    outputs.writeText(exp / "stats.toml", s.str());
    outputs.commit();
    for (const auto& e : fs::directory_iterator(exp)) {
        if (isBlessOutput(e) &&
            std::find(written.begin(), written.end(), e.path()) == written.end())
            fs::remove(e.path(), ec);
    }
}

}  // namespace

void blessScenario(const fs::path& dir, const fs::path& nvstimExe) {
    const fs::path exp = expectedFolder(dir);
    const std::vector<std::string> channels = rigChannels(dir);
    TempDir temp;
    const fs::path work = temp.path();
    (void)replayScenario(dir, nvstimExe, work);
    if (channels.empty()) {
        blessStream(dir, exp, work);
        return;
    }
    // A rig: expected/CHANNEL/ for each channel.
    std::error_code ec;
    fs::create_directory(exp, ec);
    if (ec) throw SetupError(exp.string() + ": cannot create: " + ec.message());
    for (const std::string& ch : channels) {
        const fs::path sub = exp / ch;
        if (fs::is_symlink(fs::symlink_status(sub))) {
            throw SetupError(sub.string() +
                             ": is a symbolic link; --bless writes only real folders");
        }
        blessStream(dir, sub, work / ch);
    }
}

namespace {

struct Ref {
    int first, count;
    double level, noise;
};

// One stream's expectations (expected/ or expected/CHANNEL/), read strictly.
struct Expectations {
    std::string fingerprint;
    int frames = 0;
    std::string metaSha;
    std::vector<std::string> frameSha;
    std::vector<Ref> refs;
    std::vector<ImageF> refMean, refMeanVar, refPixVar;
};

Expectations readExpectations(const fs::path& dir, const fs::path& exp) {
    if (!fs::exists(exp / "digest.toml") || !fs::exists(exp / "stats.toml")) {
        throw SetupError(dir.string() + ": no expectations in " + exp.string() +
                         " (run `nvstim replay " + dir.string() + " --bless` first)");
    }
    // Expectations, strictly.
    const ConfigDocument digestDoc = ConfigDocument::parseFile(exp / "digest.toml");
    const ConfigTable dg = digestDoc.root();
    const std::string fingerprint = dg.require<std::string>("fingerprint");
    const int expectedFrames = dg.require<int>("frames");
    const std::string metaSha = dg.require<std::string>("meta_sha256");
    const auto frameSha = dg.require<std::vector<std::string>>("frame_sha256");
    digestDoc.finish();
    // Fail closed: an expectation that could not tell a good replay from a bad one is an error.
    if (expectedFrames < 1) dg.fail("frames", "must be at least 1");
    if (static_cast<int>(frameSha.size()) != expectedFrames) {
        dg.fail("frame_sha256", "lists " + std::to_string(frameSha.size()) + " digests for " +
                                    std::to_string(expectedFrames) + " frames");
    }
    for (const std::string& d : frameSha)
        if (!isSha256Hex(d)) dg.fail("frame_sha256", "'" + d + "' is not a SHA-256 in hex");
    if (!isSha256Hex(metaSha)) dg.fail("meta_sha256", "not a SHA-256 in hex");
    const ConfigDocument statsDoc = ConfigDocument::parseFile(exp / "stats.toml");
    const ConfigTable st = statsDoc.root();
    if (st.require<int>("block_px") != kReplayBlock_px)
        st.fail("block_px", "unsupported block size");
    std::vector<Ref> refs;
    for (const ConfigTable& w : st.tableArray("window")) {
        const Ref ref{w.require<int>("first"), w.require<int>("count"),
                      w.require<double>("level_counts"), w.require<double>("noise_var_counts2")};
        // Each window inside the run (64-bit sums: no overflow), finite levels.
        if (ref.first < 0 || ref.first >= expectedFrames) {
            w.fail("first", "frame " + std::to_string(ref.first) + " is outside the run's " +
                                std::to_string(expectedFrames) + " frames");
        }
        if (ref.count < 1 || static_cast<std::int64_t>(ref.first) + ref.count > expectedFrames) {
            w.fail("count", std::to_string(ref.count) + " frames from frame " +
                                std::to_string(ref.first) + " do not fit in the run's " +
                                std::to_string(expectedFrames));
        }
        if (!std::isfinite(ref.level)) w.fail("level_counts", "not a finite number");
        if (!std::isfinite(ref.noise) || ref.noise < 0.0)
            w.fail("noise_var_counts2", "not a finite, non-negative number");
        refs.push_back(ref);
    }
    if (refs.empty()) {
        throw SetupError(FileLoc{(exp / "stats.toml").string()},
                         "no [[window]]: nothing to compare the statistics with");
    }
    statsDoc.finish();
    std::vector<ImageF> refMean, refMeanVar, refPixVar;
    for (std::size_t i = 0; i < refs.size(); ++i) {
        const std::string stem = "w" + std::to_string(i);
        refMean.push_back(readReference(exp / (stem + "_mean.pfm")));
        refMeanVar.push_back(readReference(exp / (stem + "_meanvar.pfm")));
        refPixVar.push_back(readReference(exp / (stem + "_pixvar.pfm")));
    }

    return Expectations{
        fingerprint,           expectedFrames,      metaSha, frameSha, refs, std::move(refMean),
        std::move(refMeanVar), std::move(refPixVar)};
}

// Compares one stream's replay in `work` (frames/, meta.jsonl) with its expectations; error
// images into failDir. False when it moved.
bool compareStream(const Expectations& e, const fs::path& work, const fs::path& failDir,
                   std::ostringstream& rep) {
    const auto files = framesIn(work / "frames");
    bool passed = true;
    char line[512];
    if (static_cast<int>(files.size()) != e.frames) {
        passed = false;
        std::snprintf(line, sizeof line, "  frames: %d expected, %zu replayed\n", e.frames,
                      files.size());
        rep << line;
    }
    // 1. Bit-exact digests.
    const std::string thisBuild = buildFingerprint();
    const bool sameBuild = e.fingerprint == thisBuild;
    std::vector<int> moved;
    for (std::size_t k = 0; k < files.size() && k < e.frameSha.size(); ++k) {
        if (sha256File(files[k]) != e.frameSha[k]) moved.push_back(static_cast<int>(k));
    }
    const bool metaSame = sha256File(work / "meta.jsonl") == e.metaSha;
    if (moved.empty() && metaSame && static_cast<int>(files.size()) == e.frames) {
        rep << "  bit-exact: all " << files.size() << " frames and the metadata are identical\n";
    } else {
        std::string list;
        for (std::size_t i = 0; i < moved.size() && i < 8; ++i) {
            list += (i ? ", " : "") + std::to_string(moved[i]);
        }
        if (moved.size() > 8) list += ", ...";
        std::snprintf(line, sizeof line,
                      "  bit-exact: %zu of %zu frames differ%s%s%s; metadata %s\n", moved.size(),
                      files.size(), moved.empty() ? "" : " (", list.c_str(),
                      moved.empty() ? "" : ")", metaSame ? "identical" : "differs");
        rep << line;
        if (sameBuild) passed = false;
    }
    // What decided: the digests hold only where the fingerprint is this run's. Across
    // instruction sets alone, the camera chain gives the same bits for the same radiance, but
    // Embree's kernel sets differ in the last bits of hit distances and barycentrics, so the
    // radiance (and through it the frames) differs within the tolerance of
    // docs/portability.md; the statistics decide there.
    const bool otherIsaOnly =
        !sameBuild && fingerprintWithoutIsa(e.fingerprint) == fingerprintWithoutIsa(thisBuild);
    if (sameBuild) {
        rep << "  checked: digests (bit-exact, same build and ISA \"" << isaFingerprint()
            << "\") and statistics\n";
    } else if (otherIsaOnly && moved.empty() && metaSame) {
        rep << "  checked: statistics (blessed on \"" << e.fingerprint
            << "\"; this run is the same build on ISA \"" << isaFingerprint()
            << "\", where the digests need not hold, and they hold)\n";
    } else if (otherIsaOnly) {
        rep << "  checked: statistics only (blessed on \"" << e.fingerprint
            << "\"; this run is the same build on ISA \"" << isaFingerprint()
            << "\": the renderer's radiance differs across ISAs within the stated tolerance, so "
               "digests are not comparable)\n";
    } else {
        rep << "  checked: statistics only (blessed on \"" << e.fingerprint
            << "\", this build is \"" << thisBuild << "\": digests are not comparable)\n";
    }
    // 2. Statistics per window.
    for (std::size_t i = 0; i < e.refs.size(); ++i) {
        const Ref& ref = e.refs[i];
        if (static_cast<std::int64_t>(ref.first) + ref.count >
            static_cast<std::int64_t>(files.size())) {
            // The replay came out short: the window cannot be compared, which is a failure.
            passed = false;
            rep << "  window " << i << " (frames " << ref.first << "-" << ref.first + ref.count - 1
                << "): not in the replay's " << files.size() << " frames\n";
            continue;
        }
        const std::string stem = "w" + std::to_string(i);
        const ImageF& rMean = e.refMean[i];
        const ImageF& rMeanVar = e.refMeanVar[i];
        const ImageF& rPixVar = e.refPixVar[i];
        const WindowStats w = computeWindow(files, ref.first, ref.count);
        if (w.blocksX != rMean.width() || w.blocksY != rMean.height() ||
            rMeanVar.width() != rMean.width() || rMeanVar.height() != rMean.height() ||
            rPixVar.width() != rMean.width() || rPixVar.height() != rMean.height()) {
            passed = false;
            rep << "  window " << i << ": image size changed\n";
            continue;
        }
        ImageF z(w.blocksX, w.blocksY), diff(w.blocksX, w.blocksY), ratio(w.blocksX, w.blocksY);
        int meanMoved = 0, varMoved = 0;
        double zMax = 0.0;
        int zx = 0, zy = 0;
        const double n = ref.count;
        for (int by = 0; by < w.blocksY; ++by) {
            for (int bx = 0; bx < w.blocksX; ++bx) {
                const double d =
                    static_cast<double>(w.mean(bx, by)) - static_cast<double>(rMean(bx, by));
                const double se = std::sqrt((static_cast<double>(w.meanVar(bx, by)) +
                                             static_cast<double>(rMeanVar(bx, by))) /
                                            n);
                const double zz = se > 0.0 ? d / se : (std::fabs(d) > 0.0 ? 1e3 : 0.0);
                z(bx, by) = static_cast<float>(zz);
                diff(bx, by) = static_cast<float>(d);
                if (std::fabs(zz) > kZLimit && std::fabs(d) > kMeanFloor_counts) ++meanMoved;
                if (std::fabs(zz) > zMax) zMax = std::fabs(zz), zx = bx, zy = by;
                const double pvRef = rPixVar(bx, by), pv = w.pixVar(bx, by);
                const double q = pvRef > 0.0 ? pv / pvRef : (pv > 0.0 ? 2.0 : 1.0);
                ratio(bx, by) = static_cast<float>(q);
                // Variance estimates from n frames scatter by ~√(2/(n−1)) per pixel, averaged
                // over 64 pixels: a 25 % move is far outside that for n ≥ 10.
                if (std::fabs(q - 1.0) > kVarianceTolerance && std::max(pv, pvRef) > 0.25)
                    ++varMoved;
            }
        }
        const int nb = w.blocksX * w.blocksY;
        // Whole-window test: a small shift of every block (a gain change of a few percent)
        // stays under each block's noise but not under the window's. The blocks are 8 px, wider
        // than the MTF's correlation, so their mean errors add as independent ones.
        double dSum = 0.0, seSum = 0.0, pv = 0.0, pvRef = 0.0;
        for (int by = 0; by < w.blocksY; ++by) {
            for (int bx = 0; bx < w.blocksX; ++bx) {
                dSum += static_cast<double>(diff(bx, by));
                seSum += (static_cast<double>(w.meanVar(bx, by)) +
                          static_cast<double>(rMeanVar(bx, by))) /
                         n;
                pv += static_cast<double>(w.pixVar(bx, by));
                pvRef += static_cast<double>(rPixVar(bx, by));
            }
        }
        const double zGlobal = seSum > 0.0 ? dSum / std::sqrt(seSum) : (dSum != 0.0 ? 1e3 : 0.0);
        const double varRatio = pvRef > 0.0 ? pv / pvRef : (pv > 0.0 ? 2.0 : 1.0);
        const bool globalMoved =
            std::fabs(zGlobal) > kGlobalZLimit && std::fabs(dSum / nb) > kGlobalMeanFloor_counts;
        const bool globalVarMoved = std::fabs(varRatio - 1.0) > kGlobalVarianceTolerance;
        if (globalMoved || globalVarMoved) passed = false;
        std::snprintf(
            line, sizeof line,
            "  window %zu whole image: mean shift %+.3f counts (z %.1f)%s; noise variance "
            "ratio %.4f%s\n",
            i, dSum / nb, zGlobal, globalMoved ? " MOVED" : "", varRatio,
            globalVarMoved ? " MOVED" : "");
        rep << line;
        if (meanMoved > 0 || varMoved > 0 || globalMoved || globalVarMoved) {
            passed = false;
            fs::create_directories(failDir);
            writeZMap(failDir / (stem + "_z.pgm"), z);
            io::writePfm(failDir / (stem + "_meandiff.pfm"), diff.cview());
            io::writePfm(failDir / (stem + "_varratio.pfm"), ratio.cview());
        }
        std::snprintf(
            line, sizeof line,
            "  window %zu (frames %d-%d): mean %.3f -> %.3f counts, moved in %d of %d "
            "blocks (max |z| %.1f at pixels %d,%d); noise variance %.3f -> %.3f counts^2, "
            "moved in %d blocks\n",
            i, ref.first, ref.first + ref.count - 1, ref.level, w.level, meanMoved, nb, zMax,
            zx * kReplayBlock_px, zy * kReplayBlock_px, ref.noise, w.noise, varMoved);
        rep << line;
    }
    if (fs::exists(failDir)) rep << "  error images: " << failDir.string() << "/\n";
    return passed;
}

}  // namespace

ReplayResult checkScenario(const fs::path& dir, const fs::path& nvstimExe) {
    const std::vector<std::string> channels = rigChannels(dir);
    const std::vector<std::string> streams =
        channels.empty() ? std::vector<std::string>{""} : channels;
    // Every stream's expectations first, strictly, then one replay.
    std::vector<Expectations> expected;
    for (const std::string& ch : streams)
        expected.push_back(readExpectations(dir, dir / "expected" / ch));
    TempDir temp;
    const fs::path work = temp.path();
    (void)replayScenario(dir, nvstimExe, work);
    ReplayResult r;
    r.passed = true;
    std::ostringstream rep;
    const std::string name =
        dir.filename().empty() ? dir.parent_path().filename().string() : dir.filename().string();
    const fs::path failDir = dir / "check-failures";
    fs::remove_all(failDir);
    for (std::size_t i = 0; i < streams.size(); ++i) {
        if (!streams[i].empty()) rep << "  channel " << streams[i] << ":\n";
        const bool ok = compareStream(expected[i], work / streams[i],
                                      streams[i].empty() ? failDir : failDir / streams[i], rep);
        r.passed = r.passed && ok;
    }
    r.report = "replay " + name + ": " + (r.passed ? "PASS" : "FAIL") + "\n" + rep.str();
    return r;
}

}  // namespace nvs::rt
