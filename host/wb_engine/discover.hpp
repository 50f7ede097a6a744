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
// time); x and y (a change over the field); a constant. Per screw and for every screw alike: its
// own speed, its sign, forward and backward parts, omega |omega|, omega t. Terms whose inputs do
// not vary in the log (a term of t on a 5 s log, of v on a log without sideways motion) are left
// out; so is everything on a gantry log but its moving axis.
std::vector<DictionaryTerm> term_dictionary(const Model& model, const Dataset& data);

// The scale of one term on a log (as the dictionary's): throws std::invalid_argument on a bad dof
// or form, or a term that does not vary over the log.
double term_scale(const Model& model, const Dataset& data, const std::string& dof, const std::string& form);

// Forward selection (orthogonal matching pursuit) on the linearized problem r + S c: at each round
// the column of S that lowers the training residual most joins, the coefficients are refitted by
// least squares, and the round is kept only while the held-out residual (the same columns over
// segments the fit did not see) falls by at least min_heldout_gain and the training BIC (n_eff
// samples) by at least min_bic. Returns the chosen columns in the order chosen and their
// coefficients (in units of each column's scale).
struct Selection {
  std::vector<int> columns;
  Eigen::VectorXd coefficients;
  std::vector<double> heldout_rss;  // after each round (index 0: nothing added)
  std::vector<double> train_rss;
};
Selection select_terms(const Eigen::VectorXd& r_train, const Eigen::MatrixXd& S_train, const Eigen::VectorXd& r_held,
                       const Eigen::MatrixXd& S_held, double n_eff, int max_terms, double min_heldout_gain,
                       double min_bic);

}  // namespace auger::wb
