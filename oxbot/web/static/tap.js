// An AudioWorklet that hands the microphone's samples to the page, one block at a time, with
// the context's frame of its first sample (where the robot's voice played is placed on it).
class Tap extends AudioWorkletProcessor {
  process(inputs) {
    const channel = inputs[0] && inputs[0][0];
    if (channel) this.port.postMessage({ samples: channel.slice(0), frame: currentFrame });
    return true;
  }
}
registerProcessor("tap", Tap);
