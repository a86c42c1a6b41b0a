#pragma once
// The effect catalog's forward models and fits (docs/diagnose.md, "Effects").
//
// Mean effects change the predicted frames; each is tried on top of the mean model taken so far
// (`acc`, with its prediction Y and gain/offset fit), its parameters fitted on the calibration
// frames, its prediction scored on the held-out frames:
//   phosphor_persistence  Y + w·(P_τ[X] − X): an added phosphor component of weight w, decay τ,
//                         integrated over each field as the chain's phosphor (PhosphorStage)
//   halo                  (1 − f)·Y + f·ring_R ⊛ Y: a fraction f of the photoelectrons lands on a
//                         ring of radius R around where it started (photocathode plane)
//   veiling_glare         (1 − g)·Y + g·exp(−r/s) ⊛ Y: stray light of fraction g, scale s
//   vertical_smear        Y + s·column mean(Y): charge picked up during vertical transfer
//   bright_source_protection  Y/(1 + (I/I_knee)^p): gain lowered by the cathode current I
//   mcp_saturation        Y + MTF ⊛ (Q(1 − e^(−U/Q)) − U): each pixel's MCP charge limited to
//                         Q per field, U the unblurred signal
// Noise effects change the predicted statistics: excess_noise, ebi_background (noise.cpp),
// fixed_pattern_noise (fpn_blotch.cpp).

#include <optional>

#include "sim/fit/engine.h"

namespace nvs::fit {

struct Candidate {
    Finding finding;
    MeanModel mm;  // acc with this effect
    LinFit fit;
    bool valid = false;  // parameters physical (a positive fraction, a finite time)
    std::string why;     // when not valid
    // Mean effects: the held-out χ² it removes (the sum over score tiles of the squared error's
    // fall over the tile's noise variance) less the BIC penalty k·ln(held-out pixels); the
    // greedy selection takes the significant candidate that explains the most.
    double gainChi2 = 0.0;
};

// The mean prediction taken so far, its fit and its held-out per-tile error.
struct Current {
    MeanModel mm;
    std::vector<Plane> Y;
    LinFit fit;
    std::vector<double> tileSse;
    double rms = 0.0;
};

// A valid candidate that explains less than 0.1 % of the held-out squared error (from its
// finding's held-out RMS before and after) is made invalid, with the reason in `why`. Camera
// mean effects and scenario effects alike.
Candidate& material(Candidate& c);

// Scores a candidate b + a·Y + c·B (its fit in cand.fit) against the current model on the
// held-out frames: the paired test over tiles with k extra parameters, the held-out RMS before
// and after, and the χ² it removes (Candidate::gainChi2).
void scoreCandidate(Work& w, const Current& cur, Candidate& cand, const std::vector<Plane>& Y,
                    const std::vector<Plane>* B, int k);

Candidate tryPersistence(Work& w, const Current& cur);
Candidate tryHalo(Work& w, const Current& cur);
Candidate tryGlare(Work& w, const Current& cur);
Candidate trySmear(Work& w, const Current& cur);
Candidate tryBsp(Work& w, const Current& cur);
Candidate trySaturation(Work& w, const Current& cur);

// The selected mean effects' final parameters: each refitted with the others held at their
// values (backfitting, two passes), on all frames of the subset (Work::fitAll). The greedy
// selection fits each effect on top of those before it only, so the first absorbs part of the
// later ones (a halo's fraction traded against a persistence's decay). Selection, z and the
// held-out errors stay as scored; parameters, cause and preset keys are replaced. `cur` ends
// with the refitted model, its gain and offset refitted on the calibration half.
void refitJointly(Work& w, Current& cur, std::vector<Finding>& found);

// A noise candidate's score (held-out RMS before and after, z, confidence) from a paired test of
// a tile statistic in DC².
void fillNoiseScore(Candidate& c, const Score& s, const char* observable);

// The noise effects, on the final mean model.
std::vector<Candidate> tryNoiseEffects(Work& w, const Current& cur, Result& r);

}  // namespace nvs::fit
