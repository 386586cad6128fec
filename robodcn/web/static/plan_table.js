// The preview's table: one row per method with its duration and whether it is feasible;
// an infeasible one shows the service's message and the field at fault (its code only as
// the tooltip), and the error line says the same.
import { $, COLORS, NAMES } from "./state.js";
import { showError, clearError, errorText } from "./ui.js";

function row(method, plan) {
  const tr = document.createElement("tr");
  tr.dataset.method = method;
  const cell = (text, cls) => {
    const td = document.createElement("td");
    td.textContent = text;
    if (cls) td.className = cls;
    tr.appendChild(td);
    return td;
  };
  // Built node by node: the page's Content-Security-Policy forbids inline style markup.
  const swatch = document.createElement("span");
  swatch.className = "swatch";
  swatch.style.background = COLORS[method];
  cell("").appendChild(swatch);
  cell(NAMES[method] + (method === "kenlerp" ? " β=" + parseFloat($("beta").value).toFixed(2) : ""));
  const t = plan.traj && plan.traj.t;
  cell(t ? `${t[t.length - 1].toFixed(2)} s` : "–");
  if (t) {
    cell(`feasible · ${t.length} samples`, "ok");
  } else {
    const err = plan.error || {};
    const td = cell("", "bad plan-error");
    if (err.field) {
      const field = document.createElement("code");
      field.className = "field";
      field.textContent = err.field;
      td.append(field, " ");
    }
    td.append(err.message || "infeasible");
    td.title = err.code ? `${err.code}: ${errorText(err)}` : errorText(err);
  }
  return tr;
}

/** Fill the table with [method, plan] results; `inputError` replaces them all. */
export function showPlans(results, inputError = null) {
  const tbody = $("plans").querySelector("tbody");
  if (inputError) { showError(inputError, "preview"); return; }
  tbody.replaceChildren(...results.map(([m, p]) => row(m, p)));
  const failed = results.filter(([, p]) => p.error);
  const main = results.length ? results[0][0] : null;
  if (failed.length) {
    showError(failed.map(([m, p]) => (failed.length > 1 || m !== main ? NAMES[m] + ": " : "") +
      errorText(p.error)).join("\n"), "preview");
  } else {
    clearError("preview");
  }
}
