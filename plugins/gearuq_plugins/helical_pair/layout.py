"""Layout of the per-sample coefficient vector shared by the kernel and its set-up (no numba).

The kernel (``kernel.py``), the set-up (``physics.py``) and the NumPy twin read the same
vector; every index is named here once.
"""

N_DOF = 10
N_STATE = 2 * N_DOF
MAX_HARMONICS = 8

#: Length unit of the integrated states [m]: p_i = u_i / INTERNAL_LENGTH inside the solver,
#: whatever output scale (option ``length_scale``) the caller asks for, so that ``atol`` keeps
#: one meaning (1e-8 = 0.1 pm).
INTERNAL_LENGTH = 1e-5

# layout of the per-sample coefficient vector
I_OMEGA = 0  # mesh frequency / omega_n
I_S = 1  # Li, Hu and Han's stiffness variation coefficient s (used when n_harm == 0)
I_EPS0 = 2  # constant error e_0 / L
I_EPSA = 3  # error amplitude e_a / L
I_PHI = 4  # error phase [rad]
I_ZETA = 5  # mesh damping ratio
I_V = 6  # 10 mesh direction coefficients v_i: delta = v . q - eps
I_MU = I_V + N_DOF  # 10 mass ratios m_e / M_i
I_ETA = I_MU + N_DOF  # 10 support stiffness k_i / (M_i omega_n^2)
I_XI = I_ETA + N_DOF  # 10 support damping c_i / (M_i omega_n)
I_BETA = I_XI + N_DOF  # 10 dead-zone half widths b_i / L (0: linear support)
I_B5 = I_BETA + N_DOF  # mesh half backlash b5 / L
I_G = I_B5 + 1  # 10 constant generalised loads (torques) / (M_i L omega_n^2)
# number of Fourier harmonics of the stiffness (0: Li, Hu and Han's cosine form)
I_NHARM = I_G + N_DOF
I_HARM = I_NHARM + 1  # a_1, b_1, a_2, b_2, ... relative to k_m
I_CPHI = I_HARM + 2 * MAX_HARMONICS  # cos(phi), precomputed (saves a trig call per rhs)
I_SPHI = I_CPHI + 1  # sin(phi)
I_GATE = I_SPHI + 1  # 1.0: mesh damping only in contact, force clipped to compression
N_COEF = I_GATE + 1

# switching functions (``kernel.switch``)
S_MESH_HI = 0  # d - beta_5: drive-flank contact
S_MESH_LO = 1  # d + beta_5: back-flank contact
S_SUPPORT = 2  # 2 per support DOF: p_i - beta_i, p_i + beta_i
S_CLIP_HI = S_SUPPORT + 2 * N_DOF  # gated mesh: drive-flank force kappa (d - beta_5) + 2 zeta d'
S_CLIP_LO = S_CLIP_HI + 1  # gated mesh: back-flank force kappa (d + beta_5) + 2 zeta d'
#: switching functions of the default (ungated) mesh: 2 for the mesh, 2 per support DOF
N_SWITCH = S_CLIP_HI
#: with ``mesh_damping="in_contact"``: plus the two sign changes of the flank forces
N_SWITCH_GATED = S_CLIP_LO + 1
