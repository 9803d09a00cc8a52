// Web workers for pages opened from disk.
//
// Browsers refuse to start a Worker from a file:// URL, and the site's search runs in one. On
// such pages this script puts a stand-in in place of window.Worker: the worker's script runs
// in a hidden iframe of the page, and messages pass both ways as events, as with a real worker
// (the search worker only posts and receives messages, and may load scripts). The theme's
// offline mode would fetch a shim for this from the network; docs/hooks_site.py makes the
// pages load this file instead. Served over http(s) the browser's own Worker is kept.
(function () {
  "use strict";
  if (location.protocol !== "file:") {
    return;
  }

  function loadScript(doc, src) {
    return new Promise(function (resolve, reject) {
      var script = doc.createElement("script");
      script.src = src;
      script.onload = function () {
        resolve();
      };
      script.onerror = function () {
        reject(new Error("cannot load " + src));
      };
      doc.head.appendChild(script);
    });
  }

  class FrameWorker extends EventTarget {
    constructor(url) {
      super();
      this.onmessage = null;
      this.onerror = null;
      this._pending = [];
      this._ready = false;
      var src = new URL(String(url), location.href).href;
      var frame = document.createElement("iframe");
      frame.style.display = "none";
      frame.setAttribute("aria-hidden", "true");
      (document.body || document.documentElement).appendChild(frame);
      this._frame = frame;
      var scope = frame.contentWindow;
      var doc = frame.contentDocument;
      var worker = this;
      // inside the frame, postMessage goes to this object's listeners...
      scope.postMessage = function (data) {
        setTimeout(function () {
          worker._emit("message", data);
        }, 0);
      };
      // ...and importScripts loads scripts one after another (a promise: the search worker
      // waits for it)
      scope.importScripts = function () {
        var urls = Array.prototype.slice.call(arguments);
        return urls.reduce(function (done, u) {
          return done.then(function () {
            return loadScript(doc, new URL(u, src).href);
          });
        }, Promise.resolve());
      };
      scope.addEventListener("error", function (event) {
        worker._emit("error", event.error || event.message);
      });
      loadScript(doc, src).then(
        function () {
          worker._ready = true;
          worker._pending.splice(0).forEach(function (data) {
            worker._deliver(data);
          });
        },
        function (error) {
          worker._emit("error", error);
        }
      );
    }

    _emit(type, data) {
      var event =
        type === "message"
          ? new MessageEvent("message", { data: data })
          : new ErrorEvent("error", { error: data, message: String(data) });
      this.dispatchEvent(event);
      var handler = type === "message" ? this.onmessage : this.onerror;
      if (typeof handler === "function") {
        handler.call(this, event);
      }
    }

    _deliver(data) {
      var scope = this._frame.contentWindow;
      if (!scope) {
        return;
      }
      var copy = typeof structuredClone === "function" ? structuredClone(data) : data;
      scope.dispatchEvent(new scope.MessageEvent("message", { data: copy }));
    }

    postMessage(data) {
      var worker = this;
      setTimeout(function () {
        if (worker._ready) {
          worker._deliver(data);
        } else {
          worker._pending.push(data);
        }
      }, 0);
    }

    terminate() {
      this._pending = [];
      if (this._frame.parentNode) {
        this._frame.parentNode.removeChild(this._frame);
      }
    }
  }

  window.Worker = FrameWorker;
})();
