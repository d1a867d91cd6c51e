// Drives the vendored lib/ of node-red-contrib-ctrlx-automation (the client every one of
// Bosch Rexroth's Node-RED ctrlX nodes calls) through a plan of steps, as those nodes do,
// and prints what each step gave as JSON. Ours, not the package's: tests/clients/
// test_node_red_client.py runs it against linkview's mock over loopback.
//
//   node drive.js HOST:PORT USER PASSWORD '[["read", path], ["subscribe", [paths], opts], ...]'
//
// Steps: ["read", path, data?], ["browse", path], ["metadata", path], ["write", path, data?],
// ["create", path, data?], ["delete", path], ["subscribe", [paths], options, updatesEach, ms].
// A subscribe step collects each path's updates and the errors until every path but the
// last has updatesEach of them and an error came, or ms passed; then it closes.
'use strict';

const CtrlxCore = require('./lib/CtrlxCore');
const CtrlxProblemError = require('./lib/CtrlxProblemError');

function failure(err) {
  if (err instanceof CtrlxProblemError) {
    return {
      problem: true, status: err.status, title: err.title, type: err.type, detail: err.detail,
      instance: err.instance, mainDiagnosisCode: err.mainDiagnosisCode,
      detailedDiagnosisCode: err.detailedDiagnosisCode,
      dynamicDescription: err.dynamicDescription, severity: err.severity,
    };
  }
  return { problem: false, message: String(err && err.message) };
}

async function settle(promise) {
  try {
    const ok = await promise;
    return { ok: ok === undefined ? null : ok };
  } catch (err) {
    return { error: failure(err) };
  }
}

async function subscribe(core, paths, options, updatesEach, ms) {
  const subscription = await core.datalayerSubscribe(paths, options);
  const updates = Object.fromEntries(paths.map((p) => [p, []]));
  const errors = [];
  await new Promise((resolve) => {
    const done = () => {
      const fed = paths.slice(0, -1).every((p) => updates[p].length >= updatesEach);
      if (fed && errors.length > 0) resolve();
    };
    setTimeout(resolve, ms);
    subscription.on('update', (data) => {
      (updates[data.node] = updates[data.node] || []).push(data);
      done();
    });
    subscription.on('error', (err) => {
      errors.push(failure(err));
      done();
    });
  });
  subscription.close();
  return { updates, errors };
}

async function main() {
  const [host, user, password, plan] = process.argv.slice(2);
  const core = new CtrlxCore(host, user, password);
  const results = [await settle(core.logIn())];
  for (const [what, ...args] of JSON.parse(plan)) {
    const steps = {
      read: () => core.datalayerRead(args[0], args[1]),
      browse: () => core.datalayerBrowse(args[0]),
      metadata: () => core.datalayerReadMetadata(args[0]),
      write: () => core.datalayerWrite(args[0], args[1]),
      create: () => core.datalayerCreate(args[0], args[1]),
      delete: () => core.datalayerDelete(args[0]),
      subscribe: () => subscribe(core, ...args),
    };
    results.push(await settle(steps[what]()));
  }
  results.push(await settle(core.logOut()));
  // A closed subscription's EventSource may keep a timer; the plan is done, so is the process.
  process.stdout.write(JSON.stringify(results), () => process.exit(0));
}

main().catch((err) => {
  process.stderr.write(`${err && err.stack}\n`);
  process.exit(1);
});
