#include "sim/fit/normal_eq.h"

#include <gsl/gsl_linalg.h>
#include <gsl/gsl_matrix.h>
#include <gsl/gsl_vector.h>

#include <cmath>

namespace nvs::fit {

NormalEquations::NormalEquations(int k)
    : k_(k), A_(static_cast<std::size_t>(k * k), 0.0), b_(static_cast<std::size_t>(k), 0.0) {}

void NormalEquations::add(const double* x, double y) {
    for (int i = 0; i < k_; ++i) {
        if (x[i] == 0.0) continue;
        b_[static_cast<std::size_t>(i)] += x[i] * y;
        for (int j = 0; j < k_; ++j)
            A_[static_cast<std::size_t>(i * k_ + j)] += x[i] * x[j];
    }
}

std::vector<double> NormalEquations::solve() const {
    const std::size_t k = static_cast<std::size_t>(k_);
    std::vector<double> out(k, 0.0);
    gsl_matrix* U = gsl_matrix_alloc(k, k);
    gsl_matrix* V = gsl_matrix_alloc(k, k);
    gsl_vector* S = gsl_vector_alloc(k);
    gsl_vector* work = gsl_vector_alloc(k);
    gsl_vector* rhs = gsl_vector_alloc(k);
    gsl_vector* x = gsl_vector_alloc(k);
    for (std::size_t i = 0; i < k; ++i) {
        gsl_vector_set(rhs, i, b_[i]);
        for (std::size_t j = 0; j < k; ++j)
            gsl_matrix_set(U, i, j, A_[i * k + j]);
    }
    if (gsl_linalg_SV_decomp(U, V, S, work) == 0) {
        const double top = gsl_vector_get(S, 0);
        for (std::size_t i = 0; i < k; ++i)
            if (gsl_vector_get(S, i) < 1e-10 * top) gsl_vector_set(S, i, 0.0);
        if (top > 0.0 && gsl_linalg_SV_solve(U, V, S, rhs, x) == 0)
            for (std::size_t i = 0; i < k; ++i)
                out[i] = gsl_vector_get(x, i);
    }
    for (gsl_vector* v : {S, work, rhs, x})
        gsl_vector_free(v);
    gsl_matrix_free(U);
    gsl_matrix_free(V);
    return out;
}

void weightedLine(const std::vector<double>& x, const std::vector<double>& y,
                  const std::vector<double>& wt, double& p0, double& p1, bool fix0) {
    double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (std::size_t i = 0; i < x.size(); ++i) {
        if (!(wt[i] > 0)) continue;
        sw += wt[i];
        sx += wt[i] * x[i];
        sy += wt[i] * y[i];
        sxx += wt[i] * x[i] * x[i];
        sxy += wt[i] * x[i] * y[i];
    }
    if (fix0) {
        p1 = sxx > 0 ? (sxy - p0 * sx) / sxx : 0.0;
        return;
    }
    const double det = sw * sxx - sx * sx;
    if (!(std::fabs(det) > 0)) {
        p0 = sw > 0 ? sy / sw : 0.0;
        p1 = 0.0;
        return;
    }
    p0 = (sxx * sy - sx * sxy) / det;
    p1 = (sw * sxy - sx * sy) / det;
}

}  // namespace nvs::fit
