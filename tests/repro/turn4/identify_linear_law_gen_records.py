# WRONGLY REJECTED (turn 4): records of a stage whose resonance moves exactly linearly (-2e-4 /K);
# `robrst identify --train ident/T15_a.csv ident/T32.5_a.csv ident/T50_a.csv --validate ident/T15_b.csv
# ident/T32.5_b.csv ident/T50_b.csv` fitted -1.9965e-4 +- 2.2e-7, then rejected the linear law and wrote three
# explicit models (per-model standard errors too small); its template set no Mu_max. Truth: the law holds.
"""Records of stage (a) with python-control: exact ZOH, white +/-10 V input (held 1 sample), 2 nm noise.
Temperatures 15, 32.5 and 50 C; two records each (train / validate). 25 kHz, 0.2 s."""
import math, numpy as np, control as ct
fs = 25000.0; N = 5000
k = 0.05; w0 = 2*math.pi*1300; z0 = 0.015; Tref = 25.0; r = -0.0002
rng = np.random.default_rng(4)
for T in (15.0, 32.5, 50.0):
    w = w0*(1 + r*(T - Tref))
    Pz = ct.c2d(ct.tf([k*w0*w0], [1, 2*z0*w, w*w]), 1/fs, 'zoh')
    for tag in ('a', 'b'):
        u = rng.uniform(-10, 10, N); u[:50] = 0.0           # starts at rest
        t = np.arange(N)/fs
        y = ct.forced_response(Pz, t, u).outputs + rng.normal(0, 0.002, N)
        import os; os.makedirs('ident', exist_ok=True)
        with open(f'ident/T{T:g}_{tag}.csv', 'w') as f:
            f.write(f'# stage (a) simulated with python-control, {T} C, 2 nm noise\n')
            f.write('t,u,y,temp\n')
            for i in range(N): f.write(f'{t[i]:.9g},{u[i]:.9g},{y[i]:.9g},{T}\n')
print('ok')
