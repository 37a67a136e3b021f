"""Drive the web view of `advise` in headless Chromium (tests/web_browser.rs runs this).

usage: web_browser.py flow URL OUTDIR LABEL RUN OPERATOR   (RUN: `goal 2 -1 0` or `start 3`)
       web_browser.py notoken URL OUTDIR

`flow` does what a teacher does with the mouse: run, drag a selection over the path, preview an
operator, advise, undo, eval. After each step it waits (bounded) for the session's state, read
from /api/state (the session, not the page's DOM), to show the step's effect, takes a screenshot
into OUTDIR and prints the step and that state as one JSON line. `notoken` loads the page without
its token and prints what the browser got.
"""

import json
import os
import sys
import time
import urllib.request

from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.actions.action_builder import ActionBuilder
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import Select, WebDriverWait


def browser():
    options = webdriver.ChromeOptions()
    options.binary_location = "/usr/bin/chromium"
    for arg in ["--headless=new", "--window-size=1400,1000", "--disable-gpu",
                "--no-first-run", "--disable-extensions", "--disable-dev-shm-usage"]:
        options.add_argument(arg)
    if os.geteuid() == 0:
        options.add_argument("--no-sandbox")
    driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)
    driver.set_page_load_timeout(30)
    driver.set_script_timeout(30)
    return driver


def state(url):
    api = url.replace("/?token=", "/api/state?token=")
    with urllib.request.urlopen(api, timeout=30) as res:
        return json.load(res)


def until(url, what, test, seconds):
    """The session's state once `test` holds of it, polled for at most `seconds`; a statement
    that failed meanwhile ends the wait with its diagnostic."""
    deadline = time.monotonic() + seconds
    while True:
        s = state(url)
        if test(s):
            return s
        failed = [l for l in s["log"][REPORTED[0]:] if not l["ok"]]
        if failed:
            raise SystemExit(f"waiting for {what}, `{failed[0]['statement']}` failed:\n{failed[0]['reply']}")
        if time.monotonic() > deadline:
            last = s["log"][-3:] if s.get("log") else []
            raise SystemExit(f"timed out waiting for {what}; the log's last entries: {last}")
        time.sleep(0.2)


REPORTED = [0]  # how many statements the session had logged at the last step reported


def report(driver, outdir, label, step, s):
    REPORTED[0] = len(s["log"])
    driver.save_screenshot(os.path.join(outdir, f"{label}-{step}.png"))
    brief = {k: s[k] for k in ["selection", "history", "points", "evals", "executions", "current"]}
    brief["log"] = [{k: l[k] for k in ["from", "statement", "ok"]} for l in s["log"]]
    brief["drawn"] = [d["name"] for d in (s["shown"] or {}).get("drawn", [])]
    brief["ball"] = bool((s["shown"] or {}).get("ball"))
    brief["error_shown"] = driver.find_element(By.ID, "error").is_displayed()
    brief["error_text"] = driver.find_element(By.ID, "error").text
    brief["preview_text"] = driver.find_element(By.ID, "previewtext").text
    print(json.dumps({"step": step, "state": brief}), flush=True)


def drag_over_path(driver, a, b):
    """Press on path point a, move through the points to b, release (as a mouse would)."""
    points = [driver.execute_script("return pathPointOnScreen(arguments[0])", i)
              for i in range(a, b + 1, max(1, (b - a) // 8))]
    points.append(driver.execute_script("return pathPointOnScreen(arguments[0])", b))
    actions = ActionBuilder(driver)
    x, y = points[0]
    actions.pointer_action.move_to_location(int(x), int(y)).pointer_down()
    for x, y in points[1:]:
        actions.pointer_action.move_to_location(int(x), int(y))
    actions.pointer_action.pointer_up()
    actions.perform()


def click_on_path(driver, i):
    x, y = driver.execute_script("return pathPointOnScreen(arguments[0])", i)
    actions = ActionBuilder(driver)
    actions.pointer_action.move_to_location(int(x), int(y)).pointer_down().pointer_up()
    actions.perform()


def flow(url, outdir, label, run, operator):
    driver = browser()
    try:
        driver.get(url)
        WebDriverWait(driver, 20).until(lambda d: d.find_element(By.ID, "status").text != "loading…")
        report(driver, outdir, label, "loaded", state(url))

        field, button = ("goal", "Run goal") if run.startswith("goal") else ("start", "Run start")
        box = driver.find_element(By.ID, field)
        box.clear()
        box.send_keys(run.split(maxsplit=1)[1])
        driver.find_element(By.XPATH, f"//button[text()='{button}']").click()
        s = until(url, "the run", lambda s: s["executions"] and s["shown"], 300)
        WebDriverWait(driver, 20).until(lambda d: d.find_elements(By.CSS_SELECTOR, "#path polyline"))
        report(driver, outdir, label, "run", s)

        n = s["shown"]["points"]
        a, b = n // 4, n // 2
        drag_over_path(driver, a, b)
        s = until(url, "the selection", lambda s: s["selection"], 30)
        WebDriverWait(driver, 10).until(lambda d: "select" in d.find_element(By.ID, "seltext").text)
        report(driver, outdir, label, "select", s)

        Select(driver.find_element(By.ID, "op")).select_by_value(operator)
        s = until(url, "the preview", lambda s: any(
            l["statement"].startswith(f"preview {operator}") for l in s["log"]), 30)
        WebDriverWait(driver, 10).until(
            lambda d: d.find_element(By.ID, "previewtext").text.startswith("preview "))
        report(driver, outdir, label, "preview", state(url))

        click_on_path(driver, n // 3)
        s = until(url, "why", lambda s: s["log"][-1]["statement"].startswith("why "), 30)
        WebDriverWait(driver, 10).until(lambda d: d.find_element(By.ID, "why").is_displayed())
        report(driver, outdir, label, "why", s)

        driver.find_element(By.ID, "advise").click()
        s = until(url, "the advice", lambda s: s["history"], 120)
        report(driver, outdir, label, "advise", s)

        driver.find_element(By.ID, "undo").click()
        s = until(url, "the undo", lambda s: s["history"] and s["history"][-1]["undone"], 120)
        report(driver, outdir, label, "undo", s)

        driver.find_element(By.ID, "eval").click()
        s = until(url, "the eval", lambda s: s["evals"], 600)
        WebDriverWait(driver, 10).until(lambda d: d.find_element(By.ID, "evaltext").text)
        report(driver, outdir, label, "eval", s)

        # Another client (the REPL's side) runs a statement: the page shows it without being asked.
        post = url.replace("/?token=", "/api/statement?token=")
        urllib.request.urlopen(urllib.request.Request(post, data=b"history", method="POST"), timeout=30)
        WebDriverWait(driver, 20).until(
            lambda d: "> history" in d.find_element(By.ID, "log").text.replace("\n", " "))
        report(driver, outdir, label, "event", state(url))

        box = driver.find_element(By.ID, "stmt")
        box.send_keys("advise no_such_operator(1)")
        driver.find_element(By.XPATH, "//button[text()='Do']").click()
        WebDriverWait(driver, 20).until(lambda d: d.find_element(By.ID, "error").is_displayed())
        REPORTED[0] = len(s["log"]) + 1  # this statement is meant to fail
        report(driver, outdir, label, "error", state(url))

        # A second run, and the first drawn under it (as `plot compare 0 1`).
        driver.find_element(By.XPATH, f"//button[text()='{button}']").click()
        s = until(url, "the second run", lambda s: len(s["executions"]) == 2 and s["current"] == 1, 300)
        WebDriverWait(driver, 20).until(lambda d: len(Select(d.find_element(By.ID, "overlay")).options) == 3)
        Select(driver.find_element(By.ID, "overlay")).select_by_value("0")
        WebDriverWait(driver, 20).until(lambda d: d.find_elements(By.CSS_SELECTOR, "#path polyline.overlay"))
        report(driver, outdir, label, "compare", state(url))
    finally:
        driver.quit()


def notoken(url, outdir):
    driver = browser()
    try:
        driver.get(url.split("?")[0])
        driver.save_screenshot(os.path.join(outdir, "notoken.png"))
        print(json.dumps({"step": "notoken", "source": driver.page_source}), flush=True)
    finally:
        driver.quit()


if __name__ == "__main__":
    if sys.argv[1] == "flow":
        flow(*sys.argv[2:7])
    else:
        notoken(*sys.argv[2:4])
