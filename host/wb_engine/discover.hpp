// Discovered terms (docs/workbench.md "Discovered terms"): when no library effect fits a log in
// form, `explain` proposes the missing term itself, by sparse regression of what the model leaves
// over a dictionary of physically meaningful terms (auger/term_form.hpp) built from the log. This
// header is the dictionary and the regression; explain_discover.cpp runs them on explain's model.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Dense>

#include "dataset.hpp"
#include "auger/model.hpp"

namespace auger::wb {

// One dictionary entry: where it acts, its form, and the coefficient that makes it a force of
// the dof's reference size (2 N, 0.05 N m, 0.5 rpm) at the log's typical values of its inputs,
// the scale its sensitivity is computed at and its fit starts from.
struct DictionaryTerm {
  std::string dof, form;
  double scale = 1;
};

// The dictionary for a log: per body dof (x, y, yaw) the body velocities u, v, r, each alone, its
// sign, |.| and .|.|; the products u r, v r, u v; sin and cos of the heading; u and v times
// sin 2psi and cos 2psi (ground that is harder to cross one way); t, u t, v t, r t (a change over
// time); x and y (a change over the field); a constant. The drag of every axis alike times t, x or
// y. Per screw and for every screw alike: its own speed, its sign, forward and backward parts,
// omega |omega|, omega t. Terms whose inputs do
// not vary in the log (a term of t on a 5 s log, of v on a log without sideways motion) are left
// out; so is everything on a gantry log but its moving axis.
std::vector<DictionaryTerm> term_dictionary(const Model& model, const Dataset& data);

// For each term, the index of the one with sin and cos of the heading swapped in its form
// (x: u_mps*sin2(psi_rad) and x: u_mps*cos2(psi_rad)), or -1.
std::vector<int> harmonic_partners(const std::vector<DictionaryTerm>& dict);

// The coefficient of term (dof, to) closest to (dof, from) with coefficient c over the log (least
// squares over its rows): where a simpler form of a term starts its fit.
double matched_coefficient(const Model& model, const Dataset& data, const std::string& dof, const std::string& from,
                           double c, const std::string& to);

// The scale of one term on a log (as the dictionary's): throws std::invalid_argument on a bad dof
// or form, or a term that does not vary over the log.
double term_scale(const Model& model, const Dataset& data, const std::string& dof, const std::string& form);

// Forward selection (orthogonal matching pursuit) on the linearized problem r + S c, rows split
// into folds (the log's segments, a third each). The first `nuisance` columns of S are the
// model's own parameters (the paper's sigma and D): in every least-squares fit, never chosen, so
// that a term is not refused for what they would take up (a traction lost over time is partly a
// lower sigma). At each round, of the columns that lower the residual over every fold most
// (least squares with those chosen), the one whose cross-validated residual is lowest joins (each
// fold predicted by the coefficients fitted on the others); the round is kept only while that
// residual falls by at least min_heldout_gain and the BIC over every fold (n_eff samples) by at
// least min_bic per column added. Returns the chosen terms (column - nuisance) in the order
// chosen and their coefficients over every fold (in units of each column's scale).
struct Selection {
  std::vector<int> columns;
  Eigen::VectorXd coefficients;
  std::vector<double> heldout_rss;  // cross-validated, after each round (index 0: nothing added)
  std::vector<double> train_rss;    // over every fold
};
// partner[j]: the term that is term j's form with sin and cos of the heading swapped (-1: none);
// the two are also tried together.
Selection select_terms(const std::vector<Eigen::VectorXd>& r, const std::vector<Eigen::MatrixXd>& S, int nuisance,
                       const std::vector<int>& partner, double n_eff, int max_terms, double min_heldout_gain,
                       double min_bic);

}  // namespace auger::wb
