# The two commands of the README. Both build the environment first when needed.
.PHONY: demo test bootstrap
PY := .venv/bin/python

bootstrap:
	@scripts/bootstrap.sh

# Main job: the demo scenario, writing recording (.rrd), video (.mp4) and summary.json to runs/demo.
demo: bootstrap
	$(PY) -m mjasc run tasks/demo.toml --video --out runs/demo

test: bootstrap
	$(PY) -m pytest -n 2 -q
