/* Exported by `rbenv export` from a trained rbenv policy; do not edit.
 *   run:       docs/innocube/policy
 *   algorithm: ppo (8192 env steps, seed 0)
 *   env id:    rbenv/SatelliteReorient-v1
 *   scene:     innocube-3u-train
 *   env options: {"action_mode": "acceleration_lifted", "reward_weights": {"failure": 200.0}, "scene": "docs/innocube/innocube-3u-train.toml"}
 *   observation layout (the env's raw observation, float32):
 *     obs[0..5]  rot6_err
 *     obs[6..8]  attitude_fine
 *     obs[9..11]  omega_B
 *     obs[12..14]  omega_fine
 *     obs[15..17]  wheel_speed
 *     obs[18..20]  wheel_command
 *     obs[21..23]  field_B
 *   network: 24 -> 64 -> 64 -> 6; output stage: clip
 *     clip(mu, low, high): the Gaussian's mean, clipped to the action space (SB3 predict, RLlib)
 *   per call: 6040 multiply-adds, libm calls {"tanhf": 128}, 24840 bytes of constants, 512 bytes of stack
 */
#ifndef RBENV_POLICY_H
#define RBENV_POLICY_H

#define RBENV_OBS_DIM 24
#define RBENV_ACT_DIM 6

/* The env's action for its raw observation: normalisation, network, output stage.
 * Deterministic and reentrant: no heap, no state, no global that changes. */
void rbenv_policy(const float *obs, float *action);

#endif /* RBENV_POLICY_H */
