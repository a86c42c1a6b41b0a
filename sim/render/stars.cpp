#include "sim/render/stars.h"

#include <cmath>

#include "sim/core/csv.h"
#include "sim/core/error.h"
#include "sim/core/input_file.h"
#include "sim/core/planck.h"

namespace nvs::render {

namespace {
constexpr double kRadPerDeg = 3.14159265358979323846 / 180.0;
}

std::filesystem::path starCatalogPath(const std::filesystem::path& configDir) {
    return configDir / "stars" / "bright_stars.csv";
}

StarCatalog loadStarCatalog(const std::filesystem::path& path) {
    if (!pathExists(path)) {
        throw SetupError(path.string() + ": star catalogue not found");
    }
    const CsvTable t = CsvTable::load(path);
    if (t.commentValue("source").empty()) {
        throw SetupError(FileLoc{t.file(), 1, 0}, "star catalogue without a '# source:' line");
    }
    const std::size_t cn = t.column("name"), cr = t.column("ra_deg"), cd = t.column("dec_deg"),
                      cv = t.column("v_mag");
    StarCatalog c;
    c.file = t.file();
    for (std::size_t i = 0; i < t.rowCount(); ++i) {
        const double ra = t.number(i, cr), dec = t.number(i, cd), v = t.number(i, cv);
        if (!(ra >= 0.0 && ra < 360.0)) throw SetupError(t.rowLoc(i), "ra_deg outside [0, 360)");
        if (!(dec >= -90.0 && dec <= 90.0))
            throw SetupError(t.rowLoc(i), "dec_deg outside [-90, 90]");
        if (!(v > -2.0 && v < 7.0)) throw SetupError(t.rowLoc(i), "v_mag outside (-2, 7)");
        c.name.push_back(t.row(i)[cn]);
        c.ra_rad.push_back(ra * kRadPerDeg);
        c.dec_rad.push_back(dec * kRadPerDeg);
        c.vMag.push_back(v);
    }
    if (c.size() == 0) throw SetupError(t.headerLoc(), "star catalogue has no stars");
    return c;
}

double starIlluminanceToa_lx(double vMag) {
    return std::pow(10.0, -0.4 * (vMag + 13.99));
}

double bandPerLux(const Photometry& photometry, const Spectrum& weight, double temperature_K) {
    const Spectrum b = planckRadiance_W_m2_sr_nm(temperature_K);
    return integrateProduct_nm(b, weight) / photometry.photometricIntegral(b);
}

}  // namespace nvs::render
