"""lagrange.Model gives the C++ library's numbers bit for bit (against `lagrangectl eval`'s JSON, which prints the
shortest text of each double), batches equal their single calls, and bad input raises one-line Python errors."""
import json
import os
import pydoc
import re
import shutil
import subprocess
import threading

import numpy as np
import pytest

import lagrange

SOURCE = os.environ["LAGRANGE_SOURCE_DIR"]
LAGRANGECTL = os.environ["LAGRANGECTL"]
PANDA = os.path.join(SOURCE, "config/robots/panda.urdf")
UR5 = os.path.join(SOURCE, "config/robots/ur5.urdf")
PANDA_HAND = os.path.join(SOURCE, "config/robots/panda_hand.urdf")  # a mimic finger: 8 dofs, 9 moving joints
BRANCHING = os.path.join(SOURCE, "tests/fixtures/urdf/branching.urdf")
TWO_ARMS_FLOATING = os.path.join(SOURCE, "tests/fixtures/urdf/two_arms.urdf")  # a base of mass > 0

# (name, how Model is built, eval's arguments for the same plant)
PLANTS = [
    ("pendulum", lambda m: lagrange.Model.builtin("pendulum", method=m, L=0.7, body="rod"),
     ["--plant", "pendulum", "--param", "L=0.7", "--param", "body=rod"]),
    ("arm2", lambda m: lagrange.Model.builtin("arm2", method=m, m1=1.2, L2=0.45),
     ["--plant", "arm2", "--param", "m1=1.2", "--param", "L2=0.45"]),
    ("cartpole", lambda m: lagrange.Model.builtin("cartpole", method=m),
     ["--plant", "cartpole"]),
    ("chain", lambda m: lagrange.Model.builtin("chain", method=m, m=[1.0, 0.8, 0.5], links=3,
                                               joints=["revolute", "prismatic", "revolute"]),
     ["--plant", "chain", "--links", "3", "--param", "m=1,0.8,0.5", "--param", "joints=revolute,prismatic,revolute"]),
    ("panda", lambda m: lagrange.Model.from_urdf(PANDA, method=m),
     ["--urdf", PANDA]),
    ("ur5", lambda m: lagrange.Model.from_urdf(UR5, gravity=(0.5, -1.0, -9.7), method=m),
     ["--urdf", UR5, "--gravity", "0.5,-1,-9.7"]),
    ("panda_hand", lambda m: lagrange.Model.from_urdf(PANDA_HAND, method=m),
     ["--urdf", PANDA_HAND]),
    ("branching", lambda m: lagrange.Model.from_urdf(BRANCHING, method=m, mass_scale=1.25),
     ["--urdf", BRANCHING, "--param", "mass_scale=1.25"]),
]
METHODS = {"pendulum": ["closed-form", "lagrangian", "recursive"], "arm2": ["closed-form", "lagrangian", "recursive"],
           "cartpole": ["closed-form", "lagrangian", "recursive"], "chain": ["lagrangian", "recursive"],
           "panda": ["recursive", "lagrangian"], "ur5": ["recursive"], "panda_hand": ["recursive", "lagrangian"], "branching": ["recursive", "lagrangian"]}
CASES = [(name, build, args, method) for name, build, args in PLANTS for method in METHODS[name]]


def numbers(values):
    return ",".join(repr(float(x)) for x in values)


def evaluate(args, method, q, qd, tau, frames=()):
    command = [LAGRANGECTL, "eval", *args, "--method", method, "--q", numbers(q), "--qd", numbers(qd),
               "--tau", numbers(tau)]
    for f in frames:
        command += ["--frame", f]
    r = subprocess.run(command, capture_output=True, text=True, check=True)
    return json.loads(r.stdout)


def exactly(a, b):
    """Bit for bit: the same shape and the same doubles."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return a.shape == b.shape and np.array_equal(a.view(np.uint64), b.view(np.uint64))


@pytest.mark.parametrize("name,build,args,method", CASES, ids=[f"{c[0]}-{c[3]}" for c in CASES])
def test_every_function_gives_lagrangectl_evals_doubles_bit_for_bit(name, build, args, method):
    model = build(method)
    rng = np.random.default_rng(42)
    n = model.num_dofs
    q, qd, tau = rng.uniform(-1.5, 1.5, n), rng.uniform(-2, 2, n), rng.uniform(-5, 5, n)
    frame = model.frame_names[-1]
    ref = evaluate(args, method, q, qd, tau, frames=[frame])
    assert model.method == ref["method"]
    assert model.num_dofs == ref["num_dofs"]
    assert model.joint_names == ref["joints"]
    assert exactly(model.mass_matrix(q), ref["M"])
    assert exactly(model.coriolis_matrix(q, qd), ref["C"])
    assert exactly(model.gravity(q), ref["G"])
    assert exactly(model.forward_dynamics(q, qd, tau), ref["qdd"])
    assert exactly(model.kinetic_energy(q, qd), ref["T"])
    assert exactly(model.potential_energy(q), ref["V"])
    f = ref["frames"][frame]
    R, p = model.frame_pose(frame, q)
    assert exactly(R, f["rotation"]) and exactly(p, f["position"])
    assert exactly(model.frame_jacobian(frame, q), f["jacobian"])
    assert exactly(model.frame_bias_acceleration(frame, q, qd), f["jdot_qdot"])


REFERENCE_CASES = [(kind, what, method) for kind, what, methods in [
    ("--plant", "pendulum", ["closed-form", "lagrangian", "recursive"]),
    ("--plant", "arm2", ["closed-form", "lagrangian", "recursive"]),
    ("--plant", "cartpole", ["closed-form", "lagrangian", "recursive"]),
    ("--plant", "chain", ["lagrangian", "recursive"]),
    ("--urdf", PANDA, ["recursive", "lagrangian"]),
    ("--urdf", PANDA_HAND, ["recursive"]),
] for method in methods]


@pytest.mark.parametrize("kind,what,method", REFERENCE_CASES,
                         ids=["%s-%s" % (os.path.basename(c[1]), c[2]) for c in REFERENCE_CASES])
def test_inverse_dynamics_gives_the_librarys_doubles_bit_for_bit(kind, what, method):
    # eval prints no inverse dynamics: tests/python/model_reference.cpp calls the library directly.
    model = (lagrange.Model.from_urdf(what, method=method) if kind == "--urdf"
             else lagrange.Model.builtin(what, method=method))
    rng = np.random.default_rng(13)
    q, qd, qdd = (rng.uniform(-2, 2, (3, model.num_dofs)))
    r = subprocess.run([os.environ["LAGRANGE_MODEL_REFERENCE"], kind, what, method, numbers(q), numbers(qd),
                        numbers(qdd)], capture_output=True, text=True, check=True)
    assert exactly(model.inverse_dynamics(q, qd, qdd), [float(x) for x in r.stdout.split()])


def test_inverse_dynamics_of_the_forward_dynamics_gives_back_the_torque():
    model = lagrange.Model.from_urdf(PANDA)
    rng = np.random.default_rng(7)
    q, qd, tau = rng.uniform(-1, 1, (50, 7)), rng.uniform(-1, 1, (50, 7)), rng.uniform(-10, 10, (50, 7))
    back = model.inverse_dynamics(q, qd, model.forward_dynamics(q, qd, tau))
    np.testing.assert_allclose(back, tau, rtol=0, atol=1e-9)


def test_the_lagrangian_and_recursive_paths_agree_for_the_panda():
    rec, lag = lagrange.Model.from_urdf(PANDA), lagrange.Model.from_urdf(PANDA, method="lagrangian")
    q = np.random.default_rng(3).uniform(-2, 2, (20, 7))
    np.testing.assert_allclose(rec.mass_matrix(q), lag.mass_matrix(q), rtol=0, atol=1e-10)
    np.testing.assert_allclose(rec.gravity(q), lag.gravity(q), rtol=0, atol=1e-10)


def test_the_default_method_is_evals_default():
    assert lagrange.Model.builtin("arm2").method == "closed-form"
    assert lagrange.Model.builtin("chain").method == "recursive"
    assert lagrange.Model.from_urdf(PANDA).method == "recursive"
    ref = json.loads(subprocess.run([LAGRANGECTL, "eval", "--plant", "arm2", "--q", "0.3,0.1", "--qd", "0,0"],
                                    capture_output=True, text=True, check=True).stdout)
    assert exactly(lagrange.Model.builtin("arm2").mass_matrix([0.3, 0.1]), ref["M"])


def test_names_are_evals():
    ref = json.loads(subprocess.run([LAGRANGECTL, "eval", "--urdf", PANDA, "--frames"], capture_output=True,
                                    text=True, check=True).stdout)
    assert lagrange.Model.from_urdf(PANDA).frame_names == ref["frame_names"]
    assert lagrange.Model.builtin("cartpole").joint_names == ["x", "theta"]


def test_gravity_off_leaves_no_gravity_force():
    model = lagrange.Model.from_urdf(PANDA, gravity=(0, 0, 0))
    q = np.random.default_rng(1).uniform(-1, 1, 7)
    assert np.all(model.gravity(q) == 0.0)
    assert model.potential_energy(q) == 0.0


# --- batches ---------------------------------------------------------------

def every_function(model, q, qd, x, threads=1):
    frame = model.frame_names[-1]
    return {
        "M": model.mass_matrix(q, threads=threads),
        "C": model.coriolis_matrix(q, qd, threads=threads),
        "G": model.gravity(q, threads=threads),
        "qdd": model.forward_dynamics(q, qd, x, threads=threads),
        "tau": model.inverse_dynamics(q, qd, x, threads=threads),
        "T": model.kinetic_energy(q, qd, threads=threads),
        "V": model.potential_energy(q, threads=threads),
        "pose": model.frame_pose(frame, q, threads=threads),
        "J": model.frame_jacobian(frame, q, threads=threads),
        "bias": model.frame_bias_acceleration(frame, q, qd, threads=threads),
    }


@pytest.mark.parametrize("threads", [1, 3])
def test_a_batch_equals_its_single_calls_row_by_row(threads):
    model = lagrange.Model.from_urdf(PANDA)
    rng = np.random.default_rng(11)
    q, qd, x = rng.uniform(-2, 2, (7, 7)), rng.uniform(-2, 2, (7, 7)), rng.uniform(-9, 9, (7, 7))
    batch = every_function(model, q, qd, x, threads)
    assert batch["M"].shape == (7, 7, 7) and batch["T"].shape == (7,) and batch["J"].shape == (7, 6, 7)
    assert batch["pose"][0].shape == (7, 3, 3) and batch["pose"][1].shape == (7, 3)
    for i in range(7):
        one = every_function(model, q[i], qd[i], x[i])
        for key, value in one.items():
            if key == "pose":
                assert exactly(batch[key][0][i], value[0]) and exactly(batch[key][1][i], value[1])
            else:
                assert exactly(batch[key][i], value), key


def test_arrays_in_any_layout_give_the_same_doubles():
    model = lagrange.Model.builtin("chain", links=4)
    rng = np.random.default_rng(5)
    q, qd = rng.uniform(-2, 2, (6, 4)), rng.uniform(-2, 2, (6, 4))
    want = model.coriolis_matrix(q, qd)
    big = np.zeros((12, 8))
    big[::2, ::2] = q                                    # strided rows and columns
    assert exactly(model.coriolis_matrix(big[::2, ::2], qd), want)
    assert exactly(model.coriolis_matrix(np.asfortranarray(q), qd), want)
    assert exactly(model.coriolis_matrix(q.tolist(), qd.tolist()), want)
    assert exactly(model.coriolis_matrix(q[::-1], qd[::-1]), want[::-1])
    assert exactly(model.mass_matrix(q[2, ::-1][::-1]), model.mass_matrix(q[2]))
    ints = np.array([[1, 0, -1, 2]])
    assert exactly(model.gravity(ints), model.gravity(ints.astype(np.float64)))


def test_a_single_state_is_used_for_every_row_of_a_batch():
    model = lagrange.Model.builtin("arm2")
    q = np.random.default_rng(9).uniform(-2, 2, (5, 2))
    qd = np.array([0.3, -0.7])
    out = model.kinetic_energy(q, qd)
    assert exactly(out, [model.kinetic_energy(row, qd) for row in q])


def test_an_empty_batch_gives_empty_results():
    model = lagrange.Model.builtin("arm2")
    assert model.mass_matrix(np.zeros((0, 2))).shape == (0, 2, 2)
    assert model.potential_energy(np.zeros((0, 2)), threads=4).shape == (0,)


def test_a_pendulums_angle_may_be_a_plain_number():
    model = lagrange.Model.builtin("pendulum")
    assert exactly(model.gravity(0.4), model.gravity([0.4]))
    assert isinstance(model.potential_energy(0.4), float)


def test_python_threads_share_one_model_during_batches():
    # A batch releases the GIL and uses data of its own: single calls on other threads meanwhile give the same doubles.
    model = lagrange.Model.from_urdf(PANDA)
    q = np.random.default_rng(2).uniform(-2, 2, (2000, 7))
    want = model.mass_matrix(q)
    results, errors = [], []

    def batch():
        results.append(model.mass_matrix(q, threads=2))

    def singles():
        try:
            for i in range(0, 2000, 50):
                assert exactly(model.mass_matrix(q[i]), want[i])
        except AssertionError as e:
            errors.append(e)

    workers = [threading.Thread(target=batch), threading.Thread(target=singles), threading.Thread(target=batch)]
    for t in workers:
        t.start()
    for t in workers:
        t.join()
    assert not errors
    assert len(results) == 2 and all(exactly(r, want) for r in results)


# --- errors ----------------------------------------------------------------

def raises(kind, message, call):
    with pytest.raises(kind) as e:
        call()
    assert str(e.value) == message
    assert "\n" not in str(e.value)


def test_wrong_shapes_raise_value_errors_naming_the_argument():
    m = lagrange.Model.builtin("arm2")
    raises(ValueError, "q: expected 2 values (one per joint), got 3", lambda: m.mass_matrix([1, 2, 3]))
    raises(ValueError, "qd: expected shape (N, 2), one row of 2 values per state, got (4, 3)",
           lambda: m.coriolis_matrix([0, 0], np.zeros((4, 3))))
    raises(ValueError, "q: expected an array of shape (2,) or (N, 2), got shape (1, 2, 2)",
           lambda: m.gravity(np.zeros((1, 2, 2))))
    raises(ValueError, "tau: expected 3 rows (as q), got 4",
           lambda: m.forward_dynamics(np.zeros((3, 2)), [0, 0], np.zeros((4, 2))))
    raises(ValueError, "q: expected numbers, an array of shape (2,) or (N, 2), got str", lambda: m.gravity("ab"))
    raises(ValueError, "q: expected an array of shape (2,) or (N, 2), got None", lambda: m.gravity(None))
    raises(ValueError, "threads: expected 1..1024, got 0", lambda: m.gravity(np.zeros((3, 2)), threads=0))


def test_non_finite_input_raises_a_value_error_naming_the_element():
    m = lagrange.Model.builtin("arm2")
    raises(ValueError, "q: expected finite numbers, got nan at q[1]", lambda: m.mass_matrix([0, np.nan]))
    q = np.zeros((5, 2))
    q[3, 0] = -np.inf
    raises(ValueError, "qdd: expected finite numbers, got -inf at qdd[3, 0]",
           lambda: m.inverse_dynamics(np.zeros(2), np.zeros(2), q))


def test_a_result_that_is_not_finite_raises_a_runtime_error_naming_the_state():
    m = lagrange.Model.builtin("arm2")
    qd = np.ones((4, 2))
    qd[2] = 1e300  # T = ½ qdᵀ M qd overflows
    raises(RuntimeError, "T is not finite at state 2", lambda: m.kinetic_energy(np.zeros((4, 2)), qd, threads=2))
    raises(RuntimeError, "T is not finite at this state", lambda: m.kinetic_energy([0, 0], [1e300, 1e300]))


def test_bad_models_raise_evals_messages():
    raises(ValueError, "m1: expected a positive number (kg), got -1", lambda: lagrange.Model.builtin("arm2", m1=-1))
    raises(ValueError, "zz: unknown parameter for arm2 (expected one of m1, m2, L1, L2, g)",
           lambda: lagrange.Model.builtin("arm2", zz=1))
    raises(ValueError, "m: expected 3 values (one per link), got 2",
           lambda: lagrange.Model.builtin("chain", links=3, m=[1, 2]))
    raises(ValueError, "method: chain has no closed-form path (use lagrangian or recursive)",
           lambda: lagrange.Model.builtin("chain", method="closed-form"))
    raises(ValueError, "method: a urdf robot has no closed-form path (use lagrangian or recursive)",
           lambda: lagrange.Model.from_urdf(PANDA, method="closed-form"))
    raises(ValueError, "method: expected closed-form, lagrangian or recursive, got 'fast'",
           lambda: lagrange.Model.builtin("arm2", method="fast"))
    raises(ValueError, "name: expected one of pendulum|arm2|cartpole|chain, got 'urdf' (a URDF robot: "
           "Model.from_urdf)", lambda: lagrange.Model.builtin("urdf"))
    raises(ValueError, "gravity: expected (gx, gy, gz) (3 numbers, m/s²), got 2",
           lambda: lagrange.Model.from_urdf(PANDA, gravity=(0, -9.81)))
    raises(ValueError, "frame: no frame 'tool' in this plant (frame_names lists them)",
           lambda: lagrange.Model.builtin("arm2").frame_pose("tool", [0, 0]))


def eval_error(args):
    r = subprocess.run([LAGRANGECTL, "eval", *args, "--q", "0", "--qd", "0"], capture_output=True, text=True)
    assert r.returncode == 2
    return r.stderr.strip().removeprefix("lagrangectl eval: --urdf: ")


def test_a_missing_urdf_raises_file_not_found_with_evals_message(tmp_path):
    missing = str(tmp_path / "nothing.urdf")
    raises(FileNotFoundError, eval_error(["--urdf", missing]), lambda: lagrange.Model.from_urdf(missing))


def test_a_urdf_path_may_be_bytes_or_a_file_name_that_is_not_utf8(tmp_path):
    # As open() takes them: bytes, and the str os.listdir gives for a name that is not UTF-8 (surrogate escapes).
    name = os.path.join(os.fsencode(tmp_path), b"panda\xff.urdf")
    shutil.copyfile(PANDA, name)
    q = np.random.default_rng(6).uniform(-1, 1, 7)
    want = lagrange.Model.from_urdf(PANDA).mass_matrix(q)
    assert exactly(lagrange.Model.from_urdf(name).mass_matrix(q), want)
    assert exactly(lagrange.Model.from_urdf(os.fsdecode(name)).mass_matrix(q), want)
    # A missing one is named in the message, its byte written out: one line, not an empty message.
    missing = os.path.join(os.fsencode(tmp_path), b"nothing\xff.urdf")
    with pytest.raises(FileNotFoundError) as e:
        lagrange.Model.from_urdf(missing)
    assert "nothing\\xff.urdf" in str(e.value) and "\n" not in str(e.value)
    raises(ValueError, "urdf: embedded null byte", lambda: lagrange.Model.from_urdf(PANDA + "\0.txt"))


def test_every_invalid_urdf_fixture_raises_a_value_error_with_evals_message():
    folder = os.path.join(SOURCE, "tests/fixtures/urdf/invalid")
    files = sorted(os.listdir(folder))
    assert len(files) >= 10
    for name in files:
        path = os.path.join(folder, name)
        raises(ValueError, eval_error(["--urdf", path]), lambda: lagrange.Model.from_urdf(path))


# --- documentation ---------------------------------------------------------

PUBLIC = ["from_urdf", "builtin", "num_dofs", "num_positions", "num_velocities", "floating_base", "joint_names",
          "frame_names", "method", "plant", "mass_matrix", "integrate", "difference",
          "coriolis_matrix", "gravity", "forward_dynamics", "inverse_dynamics", "kinetic_energy", "potential_energy",
          "frame_pose", "frame_jacobian", "frame_bias_acceleration",
          "center_of_mass", "centroidal_momentum_matrix", "centroidal_momentum_bias", "frame_id",
          "forward_dynamics_derivatives", "inverse_dynamics_derivatives", "step_derivatives"]  # derivatives.cpp


def test_every_public_name_is_bound_documented_and_in_the_stubs():
    stubs = open(os.path.join(os.path.dirname(lagrange.__file__), "__init__.pyi")).read()
    model_stubs = stubs[stubs.index("class Model"):stubs.index("end of lagrange.Model")]
    bound = sorted(name for name in dir(lagrange.Model) if not name.startswith("_"))
    assert bound == sorted(PUBLIC)
    for name in PUBLIC:
        assert re.search(r"def %s\(" % name, model_stubs), name
        assert getattr(lagrange.Model, name).__doc__, name


def test_help_gives_units_and_shapes():
    text = pydoc.render_doc(lagrange.Model, renderer=pydoc.plaintext)
    for phrase in ["tau = M(q) qdd + C(q, qd) qd + G(q)", "(N, n, n)", "kg·m²", "rad/s²", "local_world_aligned", "pickle",
                   "FileNotFoundError"]:
        assert phrase in text, phrase
    assert "_time_forward_dynamics" not in text


# ---- issue 32 ----------------------------------------------------------------------------------------------------

LOCAL_CASES = [("--urdf", PANDA, "panda_link8"), ("--urdf", PANDA_HAND, "panda_leftfinger"),
               ("--plant", "arm2", "tip"), ("--plant", "chain", "link2")]


@pytest.mark.parametrize("kind,what,frame", LOCAL_CASES, ids=[c[2] for c in LOCAL_CASES])
def test_the_local_frame_jacobian_is_the_librarys_in_the_frames_own_axes(kind, what, frame):
    # reference="local" is the C++ library's FrameAxes::kLocal (model_reference calls it), bit for bit, and it is
    # the world-aligned Jacobian and J̇ qd turned into the frame's axes: blockdiag(Rᵀ, Rᵀ).
    model = lagrange.Model.from_urdf(what) if kind == "--urdf" else lagrange.Model.builtin(what)
    n = model.num_dofs
    rng = np.random.default_rng(21)
    q, qd = rng.uniform(-1.5, 1.5, (2, n))
    r = subprocess.run([os.environ["LAGRANGE_MODEL_REFERENCE"], kind, what, model.method, numbers(q), numbers(qd),
                        numbers(np.zeros(n)), frame], capture_output=True, text=True, check=True)
    ref = [float(x) for x in r.stdout.split()][n:]
    J = model.frame_jacobian(frame, q, reference="local")
    b = model.frame_bias_acceleration(frame, q, qd, reference="local")
    assert exactly(J, np.reshape(ref[:6 * n], (6, n)))
    assert exactly(b, ref[6 * n:])
    R, _ = model.frame_pose(frame, q)
    J_world = model.frame_jacobian(frame, q)
    assert exactly(model.frame_jacobian(frame, q, reference="local_world_aligned"), J_world)
    np.testing.assert_allclose(J, np.vstack([R.T @ J_world[:3], R.T @ J_world[3:]]), rtol=0, atol=1e-13)
    b_world = model.frame_bias_acceleration(frame, q, qd)
    np.testing.assert_allclose(b, np.concatenate([R.T @ b_world[:3], R.T @ b_world[3:]]), rtol=0, atol=1e-13)
    # A batch gives each state's own.
    Q = rng.uniform(-1.5, 1.5, (4, n))
    batch = model.frame_jacobian(frame, Q, reference="local", threads=2)
    assert all(exactly(batch[i], model.frame_jacobian(frame, Q[i], reference="local")) for i in range(4))


def test_the_local_jacobian_gives_the_body_angular_velocity_rt_rdot():
    # Physics, not arithmetic: the angular rows of J_local q̇ are ω in the frame's axes, [ω]× = Rᵀ Ṙ (central
    # differences of R along q̇).
    model = lagrange.Model.from_urdf(PANDA)
    rng = np.random.default_rng(4)
    q, qd = rng.uniform(-1.5, 1.5, (2, 7))
    h = 1e-6
    R, _ = model.frame_pose("panda_link7", q)
    Rp, _ = model.frame_pose("panda_link7", q + h * qd)
    Rm, _ = model.frame_pose("panda_link7", q - h * qd)
    W = R.T @ (Rp - Rm) / (2 * h)
    omega = model.frame_jacobian("panda_link7", q, reference="local")[3:] @ qd
    np.testing.assert_allclose(omega, [W[2, 1], W[0, 2], W[1, 0]], rtol=0, atol=1e-7)


def test_a_reference_frame_the_model_does_not_give_raises_a_value_error():
    m = lagrange.Model.builtin("arm2")
    raises(ValueError, "reference: expected 'local_world_aligned' or 'local', got 'LOCAL'",
           lambda: m.frame_jacobian("tip", [0, 0], reference="LOCAL"))
    with pytest.raises(ValueError, match="reference: 'world'.* is not given"):
        m.frame_bias_acceleration("tip", [0, 0], [0, 0], reference="world")


def test_model_of_a_urdf_path_is_the_robot_from_urdf_builds():
    q = np.random.default_rng(8).uniform(-1, 1, 7)
    want = lagrange.Model.from_urdf(PANDA, gravity=(0, 0, -3.7))
    got = lagrange.Model(PANDA, gravity=(0, 0, -3.7))
    assert exactly(got.mass_matrix(q), want.mass_matrix(q)) and exactly(got.gravity(q), want.gravity(q))
    assert got.joint_names == want.joint_names and got.method == "recursive"
    assert lagrange.Model(PANDA, method="lagrangian").method == "lagrangian"


def test_model_of_anything_but_a_urdf_says_what_it_takes():
    raises(ValueError, "urdf: 'arm2' is a built-in plant, not a URDF file: Model.builtin('arm2', ...)",
           lambda: lagrange.Model("arm2"))
    with pytest.raises(TypeError, match=r"urdf: expected a URDF file \(str, bytes or os.PathLike\) or URDF text "
                                        r"\(str\), got int \(a built-in plant: Model.builtin\)"):
        lagrange.Model(42)
    with pytest.raises(TypeError):
        lagrange.Model()


def test_from_urdf_takes_urdf_text_as_its_file():
    # A str whose first character other than white space is '<' is the URDF itself (as simulate takes YAML text).
    with open(PANDA) as f:
        text = f.read()
    q = np.random.default_rng(9).uniform(-1, 1, 7)
    from_file, from_text = lagrange.Model.from_urdf(PANDA), lagrange.Model.from_urdf("\n  " + text)
    assert exactly(from_text.mass_matrix(q), from_file.mass_matrix(q))
    assert from_text.frame_names == from_file.frame_names
    assert exactly(lagrange.Model(text).gravity(q), from_file.gravity(q))

def test_urdf_texts_errors_are_its_files_named_urdf_text(tmp_path):
    for bad in ("<robot name='r'>", "<robot/>", text_without_inertia()):
        path = tmp_path / "bad.urdf"
        path.write_text(bad)
        with pytest.raises(ValueError) as from_file:
            lagrange.Model.from_urdf(str(path))
        with pytest.raises(ValueError) as from_text:
            lagrange.Model.from_urdf(bad)
        assert str(from_file.value).startswith(str(path) + ": ")
        assert str(from_text.value) == "<urdf text>: " + str(from_file.value)[len(str(path)) + 2:]


def text_without_inertia():
    return ("<robot name='r'><link name='a'/><link name='b'/>"
            "<joint name='j' type='revolute'><parent link='a'/><child link='b'/><axis xyz='0 0 1'/>"
            "<limit lower='-1' upper='1' effort='1' velocity='1'/></joint></robot>")


def test_a_model_pickles_as_what_built_it_and_computes_the_same_doubles(tmp_path):
    import copy
    import pickle
    # A URDF robot pickles its text, not its path: it unpickles where the file is gone.
    path = tmp_path / "robot.urdf"
    shutil.copyfile(BRANCHING, path)
    models = [lagrange.Model.from_urdf(str(path), gravity=(0.5, -1.0, -9.7), method="lagrangian", mass_scale=1.25),
              lagrange.Model.builtin("chain", links=3, m=[1.0, 0.8, 0.5], joints=["revolute", "prismatic", "revolute"]),
              lagrange.Model.builtin("arm2", method="recursive", m1=1.2)]
    blobs = [pickle.dumps(m) for m in models]
    path.unlink()
    for model, blob in zip(models, blobs):
        back = pickle.loads(blob)
        q, qd = np.random.default_rng(5).uniform(-1, 1, (2, model.num_dofs))
        assert (back.plant, back.method, back.joint_names, back.frame_names) == \
            (model.plant, model.method, model.joint_names, model.frame_names)
        assert exactly(back.mass_matrix(q), model.mass_matrix(q))
        assert exactly(back.coriolis_matrix(q, qd), model.coriolis_matrix(q, qd))
        assert exactly(back.gravity(q), model.gravity(q))
        assert exactly(copy.deepcopy(model).gravity(q), model.gravity(q))
    for state in [(99, "builtin", "arm2", None, {}), (1, "urdf"), ()]:  # another version, too short, nothing
        blank = lagrange.Model.__new__(lagrange.Model)
        with pytest.raises(ValueError, match="not a pickled lagrange.Model"):
            blank.__setstate__(state)


def _mass_matrices(model, states):
    return model.mass_matrix(states)


def test_a_model_goes_to_worker_processes_with_multiprocessing():
    import multiprocessing
    model = lagrange.Model.from_urdf(PANDA)
    states = np.random.default_rng(11).uniform(-1, 1, (4, 20, 7))
    with multiprocessing.get_context("spawn").Pool(2) as pool:
        results = pool.starmap(_mass_matrices, [(model, s) for s in states])
    for s, got in zip(states, results):
        assert exactly(got, model.mass_matrix(s))


# ---- issue 37: the fast path and out= -----------------------------------------------------------------------------

def test_the_fast_path_gives_the_general_paths_results_and_errors():
    # float64 (n,) arrays passed positionally take the fast path; lists, strided views, float32 and keywords the
    # general one: the same doubles, bit for bit, and the same messages.
    model = lagrange.Model.from_urdf(os.path.join(SOURCE, "config/robots/panda.urdf"))
    rng = np.random.default_rng(37)
    n = model.num_dofs
    q, qd, x = (rng.uniform(-1, 1, n) for _ in range(3))
    strided = lambda a: np.repeat(a, 2)[::2]
    calls = {"mass_matrix": (q,), "gravity": (q,), "forward_dynamics": (q, qd, x), "inverse_dynamics": (q, qd, x)}
    for name, args in calls.items():
        f = getattr(model, name)
        fast = f(*args)
        assert fast.dtype == np.float64 and fast.flags.c_contiguous
        np.testing.assert_array_equal(fast, f(*[list(a) for a in args]))
        np.testing.assert_array_equal(fast, f(*[strided(a) for a in args]))
        np.testing.assert_array_equal(fast, f(*args, threads=1))
        np.testing.assert_array_equal(fast, f(np.stack([args[0]] * 2), *args[1:])[1])
        bad = [a.copy() for a in args]
        bad[-1][3] = np.nan
        with pytest.raises(ValueError, match=r"^\w+: expected finite numbers, got nan at \w+\[3\]$"):
            f(*bad)
        with pytest.raises(ValueError, match=rf"^q: expected {n} values \(one per joint\), got {n + 1}$"):
            f(np.zeros(n + 1), *args[1:])
        with pytest.raises(TypeError):
            f(*args, np.zeros(n))


def test_out_takes_the_result_in_place():
    model = lagrange.Model.builtin("arm2")
    q, qd, tau = np.array([0.3, -0.4]), np.array([1.0, 0.5]), np.array([0.2, -0.1])
    out = np.empty(2)
    assert model.forward_dynamics(q, qd, tau, out=out) is out
    np.testing.assert_array_equal(out, model.forward_dynamics(q, qd, tau))
    M = np.empty((2, 2))
    assert model.mass_matrix([0.3, -0.4], out=M) is M  # the general path (a list) takes out= too
    np.testing.assert_array_equal(M, model.mass_matrix(q))
    G = np.empty((3, 2))
    assert model.gravity(np.stack([q, q, -q]), out=G) is G  # a batch: (N, n)
    np.testing.assert_array_equal(G[2], model.gravity(-q))
    tau_out = np.empty(2)
    assert model.inverse_dynamics(q, qd, tau, out=tau_out) is tau_out
    np.testing.assert_array_equal(tau_out, model.inverse_dynamics(q, qd, tau))
    for wrong in [np.empty(3), np.empty(2, dtype=np.float32), np.empty((2, 2))[:, 0], [0.0, 0.0]]:
        with pytest.raises(ValueError, match=r"^out: expected a writeable C-contiguous float64 array of shape \(2,\)"):
            model.forward_dynamics(q, qd, tau, out=wrong)
    frozen = np.empty(2)
    frozen.flags.writeable = False
    with pytest.raises(ValueError, match=r"^out: expected a writeable"):
        model.gravity(q, out=frozen)


def test_a_frame_by_its_index_is_the_frame_by_its_name():
    for model in [lagrange.Model.from_urdf(PANDA), lagrange.Model.from_urdf(TWO_ARMS_FLOATING, floating_base=True)]:
        rng = np.random.default_rng(38)
        q = rng.uniform(-1, 1, model.num_positions)
        if model.floating_base:
            q[3:7] /= np.linalg.norm(q[3:7])
        qd = rng.uniform(-1, 1, model.num_velocities)
        for k, name in enumerate(model.frame_names):
            assert model.frame_id(name) == k
            for a, b in zip(model.frame_pose(k, q), model.frame_pose(name, q)):
                np.testing.assert_array_equal(a, b)
            np.testing.assert_array_equal(model.frame_jacobian(k, q, reference="local"),
                                          model.frame_jacobian(name, q, reference="local"))
            J = np.empty((6, model.num_velocities))
            assert model.frame_jacobian(k, q, out=J) is J  # the fast path, on a fixed base
            np.testing.assert_array_equal(J, model.frame_jacobian(name, list(q)))
            np.testing.assert_array_equal(model.frame_jacobian(k, q), J)
            np.testing.assert_array_equal(model.frame_bias_acceleration(k, q, qd),
                                          model.frame_bias_acceleration(name, q, qd))
        count = len(model.frame_names)
        with pytest.raises(ValueError, match=rf"^frame: expected an index 0..{count - 1} \(frame_names\), got {count}$"):
            model.frame_jacobian(count, q)
        with pytest.raises(ValueError, match=r"^frame: expected an index .*, got -1$"):
            model.frame_pose(-1, q)
        with pytest.raises(ValueError, match=r"^frame: no frame 'nowhere' in this plant"):
            model.frame_id("nowhere")
        with pytest.raises(TypeError):
            model.frame_pose(1.0, q)
