#pragma once
// Linear least squares by the normal equations, accumulated one observation at a time (the
// structure shapes fit up to 15 coefficients over every pixel of many frames, so the design
// matrix is never stored), solved by GSL's SVD: a basis the data do not span (a level with no
// pixel) leaves a singular value that is dropped instead of failing.

#include <vector>

namespace nvs::fit {

class NormalEquations {
  public:
    explicit NormalEquations(int k);
    // One observation y with regressors x[0..k).
    void add(const double* x, double y);
    // The coefficients; singular values below 1e-10 of the largest are dropped.
    std::vector<double> solve() const;

  private:
    int k_;
    std::vector<double> A_, b_;
};

// Weighted least squares y = p0 + p1·x over the points with a positive weight (p0 kept as given
// when fix0 is set).
void weightedLine(const std::vector<double>& x, const std::vector<double>& y,
                  const std::vector<double>& wt, double& p0, double& p1, bool fix0);

}  // namespace nvs::fit
