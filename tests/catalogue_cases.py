"""The catalogue's physics terms at realistic sizes on the source paper's shaker: the cases the
catalogue tests and the batched shunt design's tests share."""

#: base model and the term's true values (SI) for each catalogue term
CASES = {
    "winding_capacitance": ("UD", {"Cp": 5e-9}),
    "second_resonance": ("UD", {"zeta2": 0.02, "omega2": 800.0, "phi2": 3.1}),
    "enclosure_port": ("UD", {"Lb": 1.3e-3, "omegab": 45.7, "zetab": 0.05}),
    "suspension_creep": ("UD", {"lambda_creep": 0.1}),
    "thermal_drift": ("UD", {"drift": 0.03}),
    "semi_inductance": ("I", {"K_semi": 0.02, "n_semi": 0.6}),
    "lr2": ("I", {"L_lr2": 1e-3, "R_lr2": 5.0}),
    "lead_impedance": ("III", {"Rl": 0.1, "Ll": 5e-5}),
    "measurement_artifact": ("UD", {"omegas": 3000.0, "delta_s": 0.02, "psi_s": 0.01}),
    # a second shaker of the same type in parallel: fs 22 % higher, R0 and coil 10 % larger
    "parallel_driver": ("UD", {"R0_2": 2.83, "omega0_2": 62.0, "phi_2": 1.9, "kcoil_2": 1.1}),
}
