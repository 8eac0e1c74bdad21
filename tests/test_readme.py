"""The README's API tour runs as written."""
import os
import re

README = os.path.join(os.path.dirname(__file__), os.pardir, "README.md")


def test_readme_api_tour_runs(tmp_path, monkeypatch):
    with open(README) as fh:
        text = fh.read()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert blocks, "README has no python block"
    monkeypatch.chdir(tmp_path)
    namespace = {}
    exec(compile(blocks[0], "README.md", "exec"), namespace)
    assert namespace["fl"].is_stable
    assert namespace["cyc"].converged and namespace["fine"].status == 4
