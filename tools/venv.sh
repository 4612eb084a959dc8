# Sourced by tools/test.sh and tools/colour-check: creates tools/.venv with
# the pinned tools/requirements.txt when it is missing or out of date.
ensure_tools_venv() {
    local venv=tools/.venv
    if [ ! -x "$venv/bin/python" ] || ! cmp -s tools/requirements.txt "$venv/.requirements"; then
        python3 -m venv "$venv"
        "$venv/bin/python" -m pip install --quiet --upgrade pip
        "$venv/bin/python" -m pip install --quiet -r tools/requirements.txt
        cp tools/requirements.txt "$venv/.requirements"
    fi
}
