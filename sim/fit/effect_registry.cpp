#include "sim/fit/effect_registry.h"

#include <cmath>

#include "sim/fit/text.h"

namespace nvs::fit {

// Each effect's file defines its accessor; this table is the only list of them.
const RegisteredEffect& frameGrabberBlur();
const RegisteredEffect& videoStreak();

const std::vector<const RegisteredEffect*>& registeredEffects() {
    static const std::vector<const RegisteredEffect*> table = {&frameGrabberBlur(), &videoStreak()};
    return table;
}

const RegisteredEffect* findRegistered(const std::string& name) {
    for (const RegisteredEffect* e : registeredEffects())
        if (name == e->name) return e;
    return nullptr;
}

std::vector<std::pair<std::string, std::string>> registeredPresetKeys(
    const RegisteredEffect& e, const std::vector<double>& p) {
    std::vector<std::pair<std::string, std::string>> keys;
    for (std::size_t j = 0; j < e.parameters.size() && j < p.size(); ++j)
        keys.push_back({e.parameters[j].key, textf("%.6g", p[j])});
    return keys;
}

void applyRegistered(const Work& w, const MeanModel& mm, std::vector<Plane>& S) {
    for (const AddedEffect& a : mm.added)
        a.effect->apply(w, a.parameters, S);
}

Candidate tryRegistered(Work& w, const Current& cur, const RegisteredEffect& e) {
    Candidate c;
    c.finding.effect = e.name;
    const std::size_t n = e.parameters.size();
    std::vector<double> p(n);
    for (std::size_t j = 0; j < n; ++j)
        p[j] = std::sqrt(e.parameters[j].lo * e.parameters[j].hi);
    // The effect acts last, on the assembled prediction: it is applied to the current one.
    auto sse = [&](const std::vector<double>& q) {
        std::vector<Plane> Y = cur.Y;
        e.apply(w, q, Y);
        const LinFit f = fitLinear(w, Y, nullptr);
        return f.ok ? f.sseCal : 1e300;
    };
    for (int round = 0; round < 2; ++round)
        for (std::size_t j = 0; j < n; ++j)
            p[j] = searchLog(
                [&](double v) {
                    std::vector<double> q = p;
                    q[j] = v;
                    return sse(q);
                },
                e.parameters[j].lo, e.parameters[j].hi, 9);
    std::vector<Plane> Y = cur.Y;
    e.apply(w, p, Y);
    c.fit = fitLinear(w, Y, nullptr);
    scoreCandidate(w, cur, c, Y, nullptr, static_cast<int>(n));
    Finding& f = c.finding;
    c.valid = c.fit.ok;
    for (std::size_t j = 0; j < n; ++j) {
        const EffectParameter& ep = e.parameters[j];
        f.parameters.push_back({ep.name, p[j]});
        if (!(p[j] > 1.02 * ep.lo && p[j] < 0.98 * ep.hi)) {
            c.valid = false;
            c.why = textf("%s %.4g %s at the edge of its search (%.4g..%.4g)", ep.name, p[j],
                          ep.unit, ep.lo, ep.hi);
        }
    }
    f.cause = e.cause(p);
    f.presetKeys = registeredPresetKeys(e, p);
    c.mm = cur.mm;
    c.mm.added.push_back({&e, p});
    return material(c);
}

}  // namespace nvs::fit
