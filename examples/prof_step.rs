use diffosi::Model;
use diffosi::dynamics::{step, Data, Tree};
use num_dual::Dual64;
fn main() {
    for contact in [true, false] {
    let model = Model::load("tests/data/contact_features_pyramidal.xml").unwrap().edited(|s| s.opt.contact = contact).unwrap();
    let n = model.nv();
    let q = model.reference_q(); let v = vec![0.0; n];
    let tau: Vec<f64> = (0..n).map(|i| (0.3 * i as f64).sin()).collect();
    let tree: Tree<Dual64> = Tree::build(&model);
    let mut data = Data::new(&tree);
    let qd: Vec<Dual64> = q.iter().enumerate().map(|(i, &x)| Dual64::new(x, if i == 34 {1.0} else {0.0})).collect();
    let vd: Vec<Dual64> = v.iter().map(|&x| Dual64::from(x)).collect();
    let td: Vec<Dual64> = tau.iter().map(|&x| Dual64::from(x)).collect();
    let (mut q1, mut v1) = (vec![Dual64::from(0.0); n], vec![Dual64::from(0.0); n]);
    step(&tree, &model.opt, &mut data, (&qd, &vd, &td), (&mut q1, &mut v1)).unwrap();
    println!("contact {contact}: dual dq33/dq34 = {}", q1[33].eps);
    }
}
