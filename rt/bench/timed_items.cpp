#include "rt/bench/timed_items.h"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <map>

namespace nvs::rt::bench {
namespace {

// Quantile q of sorted samples: the value at rank ⌊q·n⌋ (the previous `nvstim bench`'s rule).
double quantile(const std::vector<double>& sorted, double q) {
    const std::size_t i = std::min(
        sorted.size() - 1, static_cast<std::size_t>(q * static_cast<double>(sorted.size())));
    return sorted[i];
}

void summarise(TimedItem& it) {
    std::vector<double> t = it.samples_s;
    if (t.empty()) return;
    std::sort(t.begin(), t.end());
    double sum = 0.0;
    for (const double x : t)
        sum += x;
    it.ran = true;
    it.iterations = static_cast<std::int64_t>(t.size());
    it.min_s = t.front();
    it.p50_s = quantile(t, 0.5);
    it.p99_s = quantile(t, 0.99);
    it.mean_s = sum / static_cast<double>(t.size());
    std::vector<double> c = it.cpuSamples_s;
    std::sort(c.begin(), c.end());
    if (!c.empty()) it.cpuP50_s = quantile(c, 0.5);
}

// Collects each item's last (reported) trial and prints one line per item on stderr.
class Collector final : public benchmark::BenchmarkReporter {
  public:
    explicit Collector(std::map<std::string, TimedItem*> byName) : byName_(std::move(byName)) {}
    bool ReportContext(const Context& ctx) override {
        machine.mhz = ctx.cpu_info.cycles_per_second * 1e-6;
        return true;
    }
    void ReportRuns(const std::vector<Run>& runs) override {
        for (const Run& r : runs) {
            const auto f = byName_.find(r.run_name.function_name);
            if (f == byName_.end() || r.run_type != Run::RT_Iteration) continue;
            TimedItem& it = *f->second;
            if (r.error_occurred) {
                std::fprintf(stderr, "  %-34s error: %s\n", it.name.c_str(),
                             r.error_message.c_str());
                continue;
            }
            summarise(it);
            if (it.after) it.after(it);
            std::fprintf(stderr, "  %-34s p50 %10.4f ms  p99 %10.4f ms  n %6lld  %s\n",
                         it.name.c_str(), it.p50_s * 1e3, it.p99_s * 1e3,
                         static_cast<long long>(it.iterations),
                         !it.target_s               ? "(reference)"
                         : it.p50_s <= *it.target_s ? "ok"
                                                    : "OVER target");
        }
    }
    MachineInfo machine;

  private:
    std::map<std::string, TimedItem*> byName_;
};

// Google Benchmark's filter is a regular expression; ours is a plain substring.
std::string regexQuote(const std::string& text) {
    std::string out;
    for (const char c : text) {
        if (std::string_view("\\^$.|?*+()[]{}").find(c) != std::string_view::npos) out += '\\';
        out += c;
    }
    return out;
}

// The comma-separated texts of a filter (empty ones dropped).
std::vector<std::string> filterTexts(const std::string& filter) {
    std::vector<std::string> out;
    std::size_t start = 0;
    for (;;) {
        const std::size_t comma = filter.find(',', start);
        const std::string part = filter.substr(start, comma - start);
        if (!part.empty()) out.push_back(part);
        if (comma == std::string::npos) break;
        start = comma + 1;
    }
    return out;
}

}  // namespace

bool filterKeeps(const std::optional<std::string>& filter, const std::string& name) {
    if (!filter) return true;
    for (const std::string& t : filterTexts(*filter))
        if (name.find(t) != std::string::npos) return true;
    return false;
}

MachineInfo runTimedItems(std::vector<std::unique_ptr<TimedItem>>& items,
                          const std::optional<std::string>& filter) {
    std::map<std::string, TimedItem*> byName;
    for (auto& p : items) {
        TimedItem* it = p.get();
        byName[it->name] = it;
        auto* b = benchmark::RegisterBenchmark(it->name.c_str(), [it](benchmark::State& st) {
            if (!it->error.empty()) {
                st.SkipWithError(it->error.c_str());
                return;
            }
            if (it->setup) {
                std::fprintf(stderr, "nvstim bench: %s: setting up ...\n", it->name.c_str());
                try {
                    it->setup();
                } catch (const std::exception& e) {
                    // An item that cannot be set up here (no OpenGL backend, say) is reported
                    // with its reason; the others run.
                    it->error = e.what();
                    std::fprintf(stderr, "nvstim bench: %s: %s\n", it->name.c_str(),
                                 it->error.c_str());
                    st.SkipWithError(it->error.c_str());
                    return;
                }
                it->setup = nullptr;
            }
            // Google Benchmark calls this once per trial with a growing iteration count; the
            // last trial is the one reported, so each call starts the samples afresh.
            it->samples_s.clear();
            it->samples_s.reserve(static_cast<std::size_t>(st.max_iterations));
            it->cpuSamples_s.clear();
            it->cpuSamples_s.reserve(static_cast<std::size_t>(st.max_iterations));
            using Clock = std::chrono::steady_clock;
            for (auto _ : st) {
                if (it->prepare) it->prepare();
                const double c0 = threadCpu_s();
                const auto t0 = Clock::now();
                it->iteration();
                const double dt = std::chrono::duration<double>(Clock::now() - t0).count();
                it->cpuSamples_s.push_back(threadCpu_s() - c0);
                st.SetIterationTime(dt);
                it->samples_s.push_back(dt);
            }
        });
        b->UseManualTime()->MinTime(it->minTime_s)->Unit(benchmark::kMillisecond);
    }
    bool any = false;
    for (const auto& p : items)
        any = any || filterKeeps(filter, p->name);
    Collector collector(std::move(byName));
    // Google Benchmark's filter: the quoted texts as alternatives.
    std::string spec = filter ? std::string() : std::string(".");
    if (filter) {
        for (const std::string& t : filterTexts(*filter))
            spec += (spec.empty() ? "" : "|") + regexQuote(t);
    }
    if (any) benchmark::RunSpecifiedBenchmarks(&collector, spec);
    benchmark::ClearRegisteredBenchmarks();
    return collector.machine;
}

double threadCpu_s() noexcept {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

std::string timedItemJson(const TimedItem& r) {
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "{\"name\":\"%s\",\"what\":\"%s\",\"iterations\":%lld,\"min_s\":%.4g,"
                  "\"p50_s\":%.4g,\"p99_s\":%.4g,\"mean_s\":%.4g,\"cpu_p50_s\":%.4g,",
                  jsonEscape(r.name).c_str(), jsonEscape(r.what).c_str(),
                  static_cast<long long>(r.iterations), r.min_s, r.p50_s, r.p99_s, r.mean_s,
                  r.cpuP50_s);
    std::string j = buf;
    if (r.target_s) {
        std::snprintf(buf, sizeof buf, "\"target_s\":%.4g,\"meets_target\":%s", *r.target_s,
                      r.p50_s <= *r.target_s ? "true" : "false");
        j += buf;
    } else {
        j += "\"target_s\":null,\"meets_target\":null";
    }
    for (const auto& [key, value] : r.extra) {
        std::snprintf(buf, sizeof buf, ",\"%s\":%.6g", key.c_str(), value);
        j += std::isfinite(value) ? std::string(buf) : ",\"" + key + "\":null";
    }
    if (!r.note.empty()) j += ",\"note\":\"" + jsonEscape(r.note) + "\"";
    if (!r.error.empty()) j += ",\"error\":\"" + jsonEscape(r.error) + "\"";
    return j + "}";
}

}  // namespace nvs::rt::bench
