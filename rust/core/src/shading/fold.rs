//! Constant folding: an op whose inputs are all constant and that reads nothing of the
//! hit is evaluated while compiling, so it never reaches the program.

use super::program::{run_kernel, Kernel, ShadingPoint, MAX_SOCKETS};
use glam::Vec3;

/// The outputs of `kernel` if it can be evaluated now (`consts[k]` is input k's value
/// when it is constant).
pub fn fold(kernel: &Kernel, consts: &[Option<Vec3>], n_out: usize) -> Option<[Vec3; MAX_SOCKETS]> {
    if kernel.varying() {
        return None;
    }
    let mut ins = [Vec3::ZERO; MAX_SOCKETS];
    for (k, c) in consts.iter().enumerate() {
        ins[k] = (*c)?;
    }
    Some(run_kernel(kernel, &ins[..consts.len()], n_out, &ShadingPoint::default()))
}
