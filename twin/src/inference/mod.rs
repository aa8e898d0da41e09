//! General inference machinery of the twin, independent of belts: bounded local optimisation
//! (`optimise`), Markov-chain sampling (`mcmc`), and the Gaussian likelihood of a measured mean
//! slip against the twin's (`likelihood`).

pub mod likelihood;
pub mod mcmc;
pub mod optimise;
