// The eigenvalue decompositions (networked_estimation/common/eigenvalues.hpp), compiled here for
// the stability and simulation sources.
#include "networked_estimation/common/eigenvalues.hpp"

#include <Eigen/Eigenvalues>

namespace networked_estimation
{

Eigen::VectorXcd eigenvalues(const Eigen::MatrixXd& A)
{
  if (A.rows() == 0)
    return Eigen::VectorXcd();
  return Eigen::EigenSolver<Eigen::MatrixXd>(A, false).eigenvalues();
}

EigenDecomposition eigenDecomposition(const Eigen::MatrixXd& A)
{
  const Eigen::EigenSolver<Eigen::MatrixXd> es(A);
  return {es.eigenvalues(), es.eigenvectors()};
}

double spectralRadius(const Eigen::MatrixXd& A)
{
  return A.rows() == 0 ? 0.0 : eigenvalues(A).cwiseAbs().maxCoeff();
}

Eigen::VectorXd symmetricEigenvalues(const Eigen::MatrixXd& S, bool* converged)
{
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(S, Eigen::EigenvaluesOnly);
  if (converged)
    *converged = es.info() == Eigen::Success;
  return es.eigenvalues();
}

SymmetricEigenDecomposition symmetricEigenDecomposition(const Eigen::MatrixXd& S)
{
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(S);
  return {es.eigenvalues(), es.eigenvectors()};
}

}  // namespace networked_estimation
