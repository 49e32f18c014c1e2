# Every target sets up its own virtual environment from pyproject.toml,
# pinned by constraints.txt, so a fresh machine needs only Python 3.11 and make.
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp
OUT    := out

.PHONY: demo test lint typecheck bench bench-performance bench-service bench-diagnosis samples lock clean \
	wheelhouse check-container proto bench-kill bench-startup bench-trends bench-load bench-misfire browser screenshots mutation

$(STAMP): pyproject.toml constraints.txt
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else "Python >= 3.11 is required, found " + sys.version)'
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade "pip>=24"
	$(BIN)/python -m pip install --quiet -c constraints.txt -e '.[test,import,cluster]'
	@touch $(STAMP)

## demo: the main job on bundled data: diagnose the 7K98MC misfire recording against its healthy baseline
demo: $(STAMP)
	@mkdir -p $(OUT)
	$(BIN)/engine-monitor calibrate recordings/samples/7k98mc-baseline.h5 -o $(OUT)/7k98mc-baseline.json
	@# compare exits 0 healthy, 1 warning, 2 alarm (this recording: an alarm), 3 when it cannot diagnose
	$(BIN)/engine-monitor compare recordings/samples/7k98mc-misfire-cyl4.h5 \
		--baseline $(OUT)/7k98mc-baseline.json --plot $(OUT)/7k98mc-misfire-cyl4.png; \
		status=$$?; test $$status -le 2

## browser: Debian's chromium and its driver for the web pages' tests, installed when missing and the
## machine allows it (root, apt-get); elsewhere those tests skip and say why (under CI, .ci/run, they fail)
browser:
	@if command -v chromedriver >/dev/null 2>&1 && { command -v chromium >/dev/null 2>&1 || \
		command -v chromium-browser >/dev/null 2>&1; }; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
		echo "installing chromium and chromium-driver (Debian) for the web pages' tests ..."; \
		apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium chromium-driver \
			>/dev/null || echo "chromium could not be installed: the browser tests will skip (fail under CI)"; \
	else echo "no chromium and no root apt-get: the browser tests will skip (fail under CI)"; fi

## test: lint, type check, the layering of the imports (pyproject.toml) and the whole test suite
test: $(STAMP) browser
	$(BIN)/ruff check .
	$(BIN)/mypy
	$(BIN)/lint-imports --no-cache
# each module's tests on one worker: a module-scoped fixture (a simulated population, a service
# with its baselines) is then built once, not once per worker that draws one of its tests
	$(BIN)/pytest -n 2 --dist loadscope

## bench: accuracy-against-time benchmarks; rewrites the tables in docs/
bench: $(STAMP)
	$(BIN)/python -m benchmarks.accuracy_vs_time

## bench-performance: speed and memory on a generated one-hour recording (several minutes, 4 GB of
## temporary disk; installs the peer rota-order into .venv-peers/ on first use); rewrites docs/performance.md
bench-performance: $(STAMP)
	$(BIN)/python -m benchmarks.performance --minutes 60

## screenshots: the web pages' pictures in docs/images/, taken by the browser tests themselves
screenshots: $(STAMP) browser
	ENGINE_MONITOR_SCREENSHOTS=docs/images $(BIN)/pytest -q tests/report/test_web.py -k service

## bench-trends: the drift rule's false findings and delays with its baseline estimated; rewrites its
## section of docs/trends.md
bench-trends: $(STAMP)
	$(BIN)/python -m benchmarks.trends

## bench-load: the model's gas torque against the validation simulator at 25-100 % load, and a real
## single-cylinder engine's crank speed predicted from its pressure at three loads (needs ../shared);
## rewrites docs/load-response.md
bench-load: $(STAMP)
	$(BIN)/python -m benchmarks.load_response

## bench-startup: the quick commands' start-up, warm (fails when one takes 1 s or more); rewrites its section
## of docs/performance.md
bench-startup: $(STAMP)
	$(BIN)/python -m benchmarks.startup

## bench-diagnosis: the diagnosis on a population of engines from the validation simulator (540 cases at
## their baseline's operating point, 540 off it, each diagnosed with and without the load, 240 V engines'
## cases at their point and 60 off it; its document states the time the run took); rewrites
## docs/diagnosis-validation.md
bench-diagnosis: $(STAMP)
	$(BIN)/python -m benchmarks.diagnosis_validation --cases 540 --off-point-cases 540 --vee-cases 240 \
		--vee-off-point-cases 60 --workers 2

## bench-misfire: misfires and healthy runs at 25-100 % load, the charge pressure rising with load and held
## (the validation simulator; a few minutes); rewrites its table in docs/diagnosis.md
bench-misfire: $(STAMP)
	$(BIN)/python -m benchmarks.misfire_loads --engines 30 --workers 2

## mutation: the decision rules (monitor/diagnosis/findings.py) mutated, each mutant against the limit tests
## (cosmic-ray, [tool.cosmic-ray] in pyproject.toml; a few minutes); rewrites docs/mutation-testing.md
mutation: $(STAMP)
	$(BIN)/python -m pip install --quiet -c constraints.txt -e '.[mutation]'
	$(BIN)/python -m benchmarks.mutation

## bench-service: the HTTP service under load on loopback (SQLite, and PostgreSQL where a server answers);
## rewrites its section of docs/performance.md
bench-service: $(STAMP)
	$(BIN)/python -m benchmarks.service_load --seconds 20

## wheelhouse: the product and its pinned dependencies as wheels, for the container image (docker/wheelhouse/)
wheelhouse: $(STAMP)
	rm -rf docker/wheelhouse
	$(BIN)/python -m pip wheel --quiet -c constraints.txt --wheel-dir docker/wheelhouse/dependencies '.[cluster]'
	mkdir -p docker/wheelhouse/product
	mv docker/wheelhouse/dependencies/engine_monitor-*.whl docker/wheelhouse/product/

## check-container: build the image and run the compose stack for real (root; Debian's docker.io, docker-compose
## and debootstrap, installed if missing; several minutes); writes its section of docs/service.md
check-container: $(STAMP)
	$(BIN)/python -m benchmarks.container

## proto: regenerate the MCAP blocks' protobuf module from its .proto (protoc from grpcio-tools)
proto: $(STAMP)
	cd monitor/io/proto && ../../../$(BIN)/python -m grpc_tools.protoc -I. --python_out=. --pyi_out=. \
		engine_monitor/recording.proto

## bench-kill: the service killed with kill -9 mid-analysis and restarted (20 runs on SQLite, 5 on PostgreSQL),
## then flooded with 20 000 idle connections while /health is timed; rewrites their sections of docs/service.md
bench-kill: $(STAMP)
	$(BIN)/python -m benchmarks.service_kill --sqlite-runs 20 --postgresql-runs 5
	$(BIN)/python -m benchmarks.service_flood --connections 20000 --clients 2 --seconds 30

## samples: regenerate the small recordings in recordings/samples/ from their scenes (deterministic)
SAMPLES := 7k98mc-baseline:10 7k98mc-misfire-cyl4:10 6l32-misfire-cyl3:3 12v32-misfire-b3:3
samples: $(STAMP)
	@mkdir -p recordings/samples
	@for item in $(SAMPLES); do \
		name=$${item%%:*}; seconds=$${item##*:}; \
		$(BIN)/engine-monitor simulate recordings/scenes/$$name.toml --duration $$seconds \
			-o recordings/samples/$$name.h5 || exit 1; \
		$(BIN)/engine-monitor simulate --truth recordings/samples/$$name.h5 \
			> recordings/samples/$$name.expected.json || exit 1; \
	done

## lock: re-pin constraints.txt to the newest versions that satisfy pyproject.toml
lock:
	rm -rf .lock-venv
	$(PYTHON) -m venv .lock-venv
	.lock-venv/bin/python -m pip install --quiet --upgrade "pip>=24"
	.lock-venv/bin/python -m pip install --quiet -e '.[test,import,cluster,mutation]'
	.lock-venv/bin/python -m pip freeze --exclude-editable --exclude pip > constraints.txt
	rm -rf .lock-venv

clean:
	rm -rf $(VENV) .venv-peers $(OUT) .pytest_cache .mypy_cache .ruff_cache .hypothesis
