#include "sim/sky/stars.h"

#include <cmath>

#include "sim/core/csv.h"
#include "sim/core/error.h"
#include "sim/core/geometry.h"
#include "sim/core/input_file.h"
#include "sim/core/planck.h"
#include "sim/core/units.h"

namespace nvs::sky {

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

void frameStars(const StarCatalog& catalog, const double* az_rad, const double* alt_rad,
                const std::array<double, msg::kBands>& bandPerLux, const AtmosphereTable& table,
                const std::array<int, msg::kBands>& tableBand, msg::FrameSky* sky) noexcept {
    const int n = static_cast<int>(catalog.size());
    sky->starCount = 0;
    for (int k = 0; k < n; ++k) {
        const std::size_t i = static_cast<std::size_t>(k);
        if (!(alt_rad[i] > 0.0)) continue;
        msg::FrameStar& st = sky->stars[static_cast<std::size_t>(sky->starCount++)];
        st.dir_enu = enuFromAzAlt(az_rad[i], alt_rad[i]);
        const double z = 0.5 * kPi - alt_rad[i];
        const double ev = starIlluminanceToa_lx(catalog.vMag[i]);
        for (int b = 0; b < msg::kBands; ++b) {
            const int tb = tableBand[static_cast<std::size_t>(b)];
            st.irradiance[b] =
                ev * bandPerLux[static_cast<std::size_t>(b)] * table.directTransmittance(tb, z);
        }
    }
}

}  // namespace nvs::sky
