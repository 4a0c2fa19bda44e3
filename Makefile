# The two commands: `make demo` and `make test`. Each builds .venv on first use.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test lint examples bench clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[dev]"
	@echo "compiling the numba simulation kernel (once per checkout, two to three minutes)"
	$(BIN)/python -c "import hybridlab; hybridlab.simulate('models/bouncing_ball.toml', t_end=1.0)"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/python examples/trolley_stop_and_return.py --plot demo.png

test: $(STAMP)
	$(BIN)/ruff check hybridlab tests examples benchmarks
	$(BIN)/python -m mypy
	$(BIN)/python -m pytest -q -n 2 --dist loadfile

lint: $(STAMP)
	$(BIN)/ruff check hybridlab tests examples benchmarks
	$(BIN)/python -m mypy

bench: $(STAMP)
	$(BIN)/python benchmarks/run_all.py

clean:
	rm -rf $(VENV) .pytest_cache build *.egg-info
