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
	@echo "compiling the numba simulation kernel, the interval loop and the two trolley models (once per checkout, three to five minutes)"
	$(BIN)/python -c "import hybridlab; hybridlab.simulate('models/bouncing_ball.toml', t_end=1.0)"
	$(BIN)/python -c "from hybridlab.symbolic import interval_machine; interval_machine.warm()"
	$(BIN)/python -c "import hybridlab; [hybridlab.simulate(f'models/{m}.toml', t_end=0.01) for m in ('trolley', 'trolley_linear')]"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/python examples/trolley_stop_and_return.py --plot demo.png

# two test workers on two cores, each with one BLAS thread: numpy's OpenBLAS would otherwise
# start a thread per core in each worker, and the reachability tests' linear algebra,
# oversubscribed, made the suite take about 1.5 times as long (measured 270 s against 181 s)
test: $(STAMP)
	$(BIN)/ruff check hybridlab tests examples benchmarks
	$(BIN)/python -m mypy
	OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 $(BIN)/python -m pytest -q -n 2 --dist loadfile

lint: $(STAMP)
	$(BIN)/ruff check hybridlab tests examples benchmarks
	$(BIN)/python -m mypy

bench: $(STAMP)
	$(BIN)/python benchmarks/run_all.py

clean:
	rm -rf $(VENV) .pytest_cache build *.egg-info
