//! One module per subcommand: each has a clap `Args` struct and a `run` function.

pub mod demo;
pub mod scenarios;
pub mod sim;
