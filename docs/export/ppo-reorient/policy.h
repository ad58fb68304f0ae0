/* Exported by `rbenv export` from a trained rbenv policy; do not edit.
 *   run:       runs/ppo-cubesat-12u-seed0
 *   algorithm: ppo (2002944 env steps, seed 0)
 *   env id:    rbenv/SatelliteReorient-v0
 *   scene:     cubesat-12u
 *   env options: {"scene": "cubesat-12u"}
 *   observation layout (the env's raw observation, float32):
 *     obs[0..3]  q_err
 *     obs[4..6]  omega_B
 *   network: 7 -> 128 -> 128 -> 12; output stage: mean_throttle
 *     E[clip(mu + std eps, low, high)], eps ~ N(0, 1): the mean action of the clipped Gaussian PPO policy (RunPolicy's mean_throttle)
 *   per call: 18823 multiply-adds, libm calls {"erfcf": 36, "expf": 24, "tanhf": 256}, 76584 bytes of constants, 1024 bytes of stack
 */
#ifndef RBENV_POLICY_H
#define RBENV_POLICY_H

#define RBENV_OBS_DIM 7
#define RBENV_ACT_DIM 12

/* The env's action for its raw observation: normalisation, network, output stage.
 * Deterministic and reentrant: no heap, no state, no global that changes. */
void rbenv_policy(const float *obs, float *action);

#endif /* RBENV_POLICY_H */
