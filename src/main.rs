use mujoco_rs::prelude::*;
fn main() {
    let m = MjModel::from_xml_string("<mujoco><worldbody><body><freejoint/><geom size='.1'/></body></worldbody></mujoco>").expect("model");
    let mut d = MjData::new(&m);
    for _ in 0..100 { d.step(); }
    println!("z = {}", d.qpos()[2]);
}
