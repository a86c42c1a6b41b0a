// The description of a structure found (structure.h): summary parameters, cause line, and
// its curve or map in the report.
#include <algorithm>

#include "sim/fit/structure_shapes.h"

namespace nvs::fit::shapes {

void describe(const Work& w, Kind k, const Frames& f, const ShapeFit& t, Finding& fd, Result& r) {
    const std::string tag = std::string("unexplained_") + kShapes[k].name;
    std::string shape;
    switch (k) {
        case kSmoothGain: {
            Plane map(static_cast<std::size_t>(w.w) * w.h, 1.0f);
            double lo = 1e300, hi = -1e300, corners = 0.0;
            for (int y = 0; y < w.h; ++y)
                for (int x = 0; x < w.w; ++x) {
                    const double* lx = &f.lx[static_cast<std::size_t>(x) * (kLegendreDegree + 1)];
                    const double* ly = &f.ly[static_cast<std::size_t>(y) * (kLegendreDegree + 1)];
                    double g = 0.0;
                    int n = 0;
                    for (int dx = 0; dx <= kLegendreDegree; ++dx)
                        for (int dy = 0; dx + dy <= kLegendreDegree; ++dy)
                            g += t.coef[static_cast<std::size_t>(n++)] * lx[dx] * ly[dy];
                    map[static_cast<std::size_t>(y) * w.w + x] = static_cast<float>(1.0 + g);
                    lo = std::min(lo, 1.0 + g);
                    hi = std::max(hi, 1.0 + g);
                    if ((x == 0 || x == w.w - 1) && (y == 0 || y == w.h - 1))
                        corners += 0.25 * (1.0 + g);
                }
            const float centre = map[static_cast<std::size_t>(w.h / 2) * w.w + w.w / 2];
            fd.parameters = {{"gain_min_rel", lo},
                             {"gain_max_rel", hi},
                             {"corner_over_centre", corners / centre}};
            shape = "the gain ranges " + fmt(3, lo) + "-" + fmt(3, hi) +
                    " over the frame, corners " + fmt(3, corners / centre) + " of the centre";
            r.maps.push_back({tag, std::move(map)});
            break;
        }
        case kFixedColumns:
        case kFixedRows: {
            const bool cols = k == kFixedColumns;
            fd.parameters = {{"rms_dc", rmsOf(t.coef)}};
            shape = fmt(2, rmsOf(t.coef)) + " DC rms between " + (cols ? "columns" : "rows");
            Curve c{tag, cols ? "column" : "row", "offset [DC]", {"fitted"}, {{}}, {{}}};
            for (std::size_t j = 0; j < t.coef.size(); ++j) {
                c.x[0].push_back(static_cast<double>(j));
                c.y[0].push_back(t.coef[j]);
            }
            r.curves.push_back(std::move(c));
            break;
        }
        case kPointMirror:
            fd.parameters = {{"fraction_sharp", t.coef[0]}, {"fraction_blurred", t.coef[1]}};
            shape = fmt(3, mirrorFraction(t.coef)) + " of the light as a point-mirrored copy";
            break;
        case kLevel: {
            Curve c{tag, "predicted level [DC]", "measured - predicted [DC]", {"fitted"}, {{}},
                    {{}}};
            double worst = 0.0, at = 0.0;
            for (int j = 0; j < kLevelKnots; ++j) {
                const double lv = knotLevel(f.levelLo, f.levelHi, j);
                c.x[0].push_back(lv);
                c.y[0].push_back(t.coef[static_cast<std::size_t>(j)]);
                if (std::fabs(t.coef[static_cast<std::size_t>(j)]) > std::fabs(worst)) {
                    worst = t.coef[static_cast<std::size_t>(j)];
                    at = lv;
                }
            }
            fd.parameters = {{"largest_deviation_dc", worst}, {"at_level_dc", at}};
            shape = "the response departs from the model's by up to " + fmt(1, worst) + " DC at " +
                    fmt(0, at) + " DC";
            r.curves.push_back(std::move(c));
            break;
        }
        case kFrameGain:
        case kFrameRows:
        case kFrameShift: {
            std::vector<double> g, o;
            Curve c{tag, "held-out frame", k == kFrameShift ? "shift [px]" : "value", {}, {}, {}};
            for (const auto& pf : t.perFrame) {
                if (k == kFrameRows) {
                    g.push_back(rmsOf(pf));
                } else {
                    g.push_back(pf[0]);
                    o.push_back(pf[1]);
                }
            }
            auto centred = [](std::vector<double> v) {
                double m = 0.0;
                for (double x : v)
                    m += x;
                m /= static_cast<double>(std::max<std::size_t>(v.size(), 1));
                for (double& x : v)
                    x -= m;
                return v;
            };
            if (k == kFrameGain) {
                fd.parameters = {{"gain_rms_rel", rmsOf(centred(g))},
                                 {"offset_rms_dc", rmsOf(centred(o))}};
                shape = "the gain varies " + fmt(3, rmsOf(centred(g))) +
                        " rms between frames, the offset " + fmt(2, rmsOf(centred(o))) + " DC";
                c.series = {"gain change", "offset change [DC]"};
                c.x = {{}, {}};
                c.y = {g, o};
            } else if (k == kFrameRows) {
                fd.parameters = {{"rms_dc", rmsOf(g)}};
                shape = fmt(2, rmsOf(g)) + " DC rms of row offsets in a frame";
                c.series = {"row offsets rms [DC]"};
                c.x = {{}};
                c.y = {g};
            } else {
                // R = α·∂Y/∂x + β·∂Y/∂y: the image moved by (−α, −β) px.
                std::vector<double> s;
                for (std::size_t i = 0; i < g.size(); ++i)
                    s.push_back(std::hypot(g[i], o[i]));
                fd.parameters = {{"shift_rms_px", rmsOf(s)}};
                shape = fmt(2, rmsOf(s)) + " px rms of frame-to-frame shift";
                c.series = {"x", "y"};
                c.x = {{}, {}};
                c.y = {centred(g), centred(o)};
                for (double& v : c.y[0])
                    v = -v;
                for (double& v : c.y[1])
                    v = -v;
            }
            for (std::size_t s = 0; s < c.series.size(); ++s)
                for (std::size_t i = 0; i < c.y[s].size(); ++i)
                    c.x[s].push_back(static_cast<double>(w.sub[i]));
            r.curves.push_back(std::move(c));
            break;
        }
        case kLag:
            fd.parameters = {{"fraction", t.coef[0]}};
            shape = fmt(3, t.coef[0]) + " of the previous frame's change carried";
            break;
        default:
            break;
    }
    fd.cause = std::string("not explained by the catalog: ") + kShapes[k].what + "; " + shape +
               ", " + fmt(1, 100.0 * fd.share) + " % of the held-out squared error";
}

}  // namespace nvs::fit::shapes
