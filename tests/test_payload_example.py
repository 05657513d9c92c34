"""examples/payload_pick.py with --quick: an independent Drake simulation of a pick.

The payload is added to the iiwa's last body in the simulated plant's Context
(Drake's dynamics, the controller's torques, seeded noise): the truth is the
payload given to Drake, never the library's regressor.
"""

import re

from test_examples import load_example


def test_payload_pick_quick(tmp_path, capsys):
    example = load_example("payload_pick")
    assert example.main(["--quick", "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    assert (tmp_path / "payload_pick.png").stat().st_size > 10_000
    settle = float(re.search(r"from ([0-9.]+|inf) s after the pick", printed).group(1))
    assert settle <= 1.0  # the mass within 5 % within a second of the pick
    error = float(re.search(r"mass error: ([+-][0-9.]+) %", printed).group(1))
    assert abs(error) < 1.0
    # Mass and the first moments are identified and within 3 σ of the truth.
    for name in ("M", "MX", "MY", "MZ"):
        row = re.search(rf"\| {name} \| (\S+) \| (\S+) \| (\S+) \| (\w+) \|", printed)
        truth, estimate, sigma, flag = row.groups()
        assert flag == "yes"
        assert abs(float(estimate) - float(truth)) <= 3.0 * float(sigma)
